"""The Panda's visual meshes with fewer triangles: what a camera sees of the arm, drawn for less.

``pybullet_data``'s Panda visual meshes hold about 100k triangles; TinyRenderer's cost per frame grows
with them (two thirds of a 320x240 frame with the arm in view). :func:`decimated_visual_dir` writes each
visual mesh again with quadric edge-collapse decimation (the ``fast-simplification`` library), one
material group at a time so that every group keeps its material, and each kept vertex keeps the texture
coordinate of the nearest original vertex of its group (the Panda's texture is a palette: a group's
colour is nearly uniform). Faces are written flat-shaded, as the source meshes are (``s off``).

The files go to a cache directory under the temporary directory, named by a digest of the sources and
the settings, written once per machine (atomically: concurrent workers write the same bytes).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from dataclasses import dataclass, field

import numpy as np

DECIMATION_VERSION = 3
"""Bumped when the written meshes would change for the same sources and settings."""
WHOLE_BELOW = 1000
"""A material group keeps at least this many triangles (a smaller one is kept whole): decimating a small group
to a tenth collapses the feature it draws (a 7 cm shell of 41 triangles became 3; the hand's 20 cm body of
3548 triangles moved 7 mm at 353), while such groups hold a small share of the total."""


@dataclass
class _Group:
    """One ``usemtl`` group of an OBJ file: its faces' position and texture indices (0-based, -1: none)."""

    material: str
    v: list[tuple[int, int, int]] = field(default_factory=list)
    vt: list[tuple[int, int, int]] = field(default_factory=list)


def _read_obj(path: str) -> tuple[str | None, np.ndarray, np.ndarray, list[_Group]]:
    """(mtllib, positions (N, 3), texture coordinates (M, 2), groups) of a triangulated OBJ file."""
    mtllib: str | None = None
    pos: list[list[float]] = []
    uv: list[list[float]] = []
    groups: list[_Group] = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            if line.startswith("v "):
                pos.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("vt "):
                uv.append([float(x) for x in line.split()[1:3]])
            elif line.startswith("usemtl"):
                groups.append(_Group(line.split(maxsplit=1)[1].strip()))
            elif line.startswith("mtllib"):
                mtllib = line.split(maxsplit=1)[1].strip()
            elif line.startswith("f "):
                corners = [c.split("/") for c in line.split()[1:]]
                if len(corners) != 3:
                    raise ValueError(f"{path}: a face with {len(corners)} corners (triangles only)")
                if not groups:
                    groups.append(_Group(""))
                groups[-1].v.append(tuple(int(c[0]) - 1 for c in corners))  # type: ignore[arg-type]
                groups[-1].vt.append(tuple(int(c[1]) - 1 if len(c) > 1 and c[1] else -1  # type: ignore[arg-type]
                                           for c in corners))
    return mtllib, np.asarray(pos, float).reshape(-1, 3), np.asarray(uv, float).reshape(-1, 2), groups


def _decimate_group(pos: np.ndarray, uv: np.ndarray, g: _Group, keep: float
                    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """(points (P, 3), their texture coordinates (P, 2) or None, triangles (T, 3)) of one group with about
    ``keep`` of its triangles (a group of fewer than :data:`WHOLE_BELOW` triangles is kept whole)."""
    import fast_simplification
    from scipy.spatial import cKDTree

    faces = np.asarray(g.v, np.int64)
    used, tri = np.unique(faces, return_inverse=True)
    tri = tri.reshape(-1, 3)
    pts = pos[used]
    corner_uv = np.asarray(g.vt, np.int64)
    vert_uv: np.ndarray | None = None
    if (corner_uv >= 0).all() and len(uv):
        vert_uv = np.zeros((len(used), 2))
        vert_uv[tri.ravel()] = uv[corner_uv.ravel()]  # one coordinate per position (the palette is uniform)
    if len(tri) > WHOLE_BELOW and keep < 1.0:
        target = max(round(keep * len(tri)), WHOLE_BELOW)
        new_pts, new_tri = fast_simplification.simplify(pts, tri.astype(np.int32), target_count=target)
        if vert_uv is not None:
            _, nearest = cKDTree(pts).query(new_pts)
            vert_uv = vert_uv[nearest]
        pts, tri = new_pts, np.asarray(new_tri, np.int64)
    return pts, vert_uv, tri


def write_decimated_obj(src: str, dst: str, keep: float) -> tuple[int, int]:
    """Write ``src`` (a triangulated OBJ) to ``dst`` with about ``keep`` of its triangles per material group;
    returns (triangles before, after). The ``mtllib`` line is kept as it is (copy the library beside ``dst``)."""
    mtllib, pos, uv, groups = _read_obj(src)
    lines = [f"# {os.path.basename(src)} decimated to {keep:g} of its triangles (code_as_monitor.sim.robot_meshes)"]
    if mtllib:
        lines.append(f"mtllib {mtllib}")
    n_v = n_vt = n_vn = 0
    before = after = 0
    for g in groups:
        if not g.v:
            continue
        pts, vert_uv, tri = _decimate_group(pos, uv, g, keep)
        a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
        normal = np.cross(b - a, c - a)
        length = np.linalg.norm(normal, axis=1)
        ok = length > 1e-12  # collapsed slivers draw nothing
        tri, normal = tri[ok], normal[ok] / length[ok, None]
        before += len(g.v)
        after += len(tri)
        lines.append(f"o {g.material or 'mesh'}")
        if g.material:
            lines.append(f"usemtl {g.material}")
        lines.append("s off")
        lines.extend(f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in pts)
        if vert_uv is not None:
            lines.extend(f"vt {u:.6f} {w:.6f}" for u, w in vert_uv)
        lines.extend(f"vn {x:.6f} {y:.6f} {z:.6f}" for x, y, z in normal)
        for k, (i, j, m) in enumerate(tri):
            n = n_vn + k + 1
            if vert_uv is not None:
                lines.append(f"f {n_v + i + 1}/{n_vt + i + 1}/{n} {n_v + j + 1}/{n_vt + j + 1}/{n} "
                             f"{n_v + m + 1}/{n_vt + m + 1}/{n}")
            else:
                lines.append(f"f {n_v + i + 1}//{n} {n_v + j + 1}//{n} {n_v + m + 1}//{n}")
        n_v += len(pts)
        n_vt += len(pts) if vert_uv is not None else 0
        n_vn += len(tri)
    with open(dst, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return before, after


def decimated_visual_dir(visual_dir: str, keep: float) -> str:
    """A directory holding every ``*.obj`` of ``visual_dir`` decimated to about ``keep`` of its triangles,
    beside copies of the directory's other files (material libraries, textures); built once, cached."""
    import fast_simplification

    names = sorted(os.listdir(visual_dir))
    h = hashlib.sha256(f"{DECIMATION_VERSION} {keep!r} {fast_simplification.__version__}".encode())
    for name in names:
        with open(os.path.join(visual_dir, name), "rb") as fh:
            h.update(name.encode() + b"\0" + hashlib.sha256(fh.read()).digest())
    cache = os.path.join(tempfile.gettempdir(), f"code_as_monitor-{os.getuid()}")
    out = os.path.join(cache, f"panda_visual_{h.hexdigest()[:12]}")
    if os.path.isdir(out):
        return out
    os.makedirs(cache, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="panda_visual_", dir=cache)
    try:
        for name in names:
            src = os.path.join(visual_dir, name)
            if name.endswith(".obj"):
                write_decimated_obj(src, os.path.join(tmp, name), keep)
            else:
                shutil.copyfile(src, os.path.join(tmp, name))
        try:
            os.rename(tmp, out)  # atomic; fails if another worker got there first (same bytes)
        except OSError:
            if not os.path.isdir(out):
                raise
    finally:
        if os.path.isdir(tmp):
            shutil.rmtree(tmp, ignore_errors=True)
    return out
