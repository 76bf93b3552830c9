"""The Panda's decimated visual meshes: fewer triangles, the same shape, materials and texture kept."""

from __future__ import annotations

import os

import numpy as np
import pytest

from code_as_monitor.sim.robot_meshes import _read_obj, decimated_visual_dir, write_decimated_obj

pybullet_data = pytest.importorskip("pybullet_data")
PIXEL_M = 2.4e-3
VISUAL = os.path.join(pybullet_data.getDataPath(), "franka_panda", "meshes", "visual")


def _triangles(path: str) -> dict[str, np.ndarray]:
    """Per material: the (T, 3, 3) corner positions of the file's triangles."""
    _, pos, _, groups = _read_obj(path)
    out: dict[str, list[np.ndarray]] = {}
    for g in groups:
        if g.v:
            out.setdefault(g.material, []).append(pos[np.asarray(g.v)])
    return {k: np.concatenate(v) for k, v in out.items()}


def _area(tri: np.ndarray) -> float:
    return float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())


def _surface_points(tri: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) points drawn uniformly on the triangles' surface."""
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    t = tri[rng.choice(len(tri), n, p=area / area.sum())]
    r1, r2 = np.sqrt(rng.random(n)), rng.random(n)
    return (1 - r1)[:, None] * t[:, 0] + (r1 * (1 - r2))[:, None] * t[:, 1] + (r1 * r2)[:, None] * t[:, 2]


def test_the_decimated_arm_has_a_fifth_of_the_triangles(tmp_path):
    before = after = 0
    for link in sorted(f for f in os.listdir(VISUAL) if f.endswith(".obj")):
        b, a = write_decimated_obj(os.path.join(VISUAL, link), str(tmp_path / link), 0.1)
        before, after = before + b, after + a
    assert after < 0.25 * before


@pytest.mark.parametrize("link", ["link1.obj", "link5.obj", "link6.obj", "hand.obj", "finger.obj"])
def test_a_decimated_link_keeps_its_shape_and_materials(tmp_path, link):
    from scipy.spatial import cKDTree

    src = os.path.join(VISUAL, link)
    write_decimated_obj(src, str(tmp_path / link), 0.1)
    old, new = _triangles(src), _triangles(str(tmp_path / link))
    assert set(new) == set(old)  # every material group is still there, drawn with its own material
    a, b = np.concatenate(list(old.values())), np.concatenate(list(new.values()))
    rng = np.random.default_rng(0)
    pa, pb = _surface_points(a, 100_000, rng), _surface_points(b, 100_000, rng)
    # both surfaces lie within two pixels of each other almost everywhere (the figure includes the samples'
    # own spacing, about a millimetre; a 320x240 default view's pixel covers about 2.4 mm at 0.7 m)
    assert np.percentile(cKDTree(pa).query(pb)[0], 99) < 2 * PIXEL_M
    assert np.percentile(cKDTree(pb).query(pa)[0], 99) < 2 * PIXEL_M
    assert abs(_area(b) - _area(a)) < 0.05 * _area(a)


def test_keeping_every_triangle_rewrites_the_same_mesh(tmp_path):
    src = os.path.join(VISUAL, "link3.obj")
    before, after = write_decimated_obj(src, str(tmp_path / "link3.obj"), 1.0)
    assert before - after <= 0.001 * before  # only zero-area slivers are dropped
    old, new = _triangles(src), _triangles(str(tmp_path / "link3.obj"))
    from scipy.spatial import cKDTree

    for k in old:  # the same corners (written to a micrometre) and the same area
        assert cKDTree(old[k].reshape(-1, 3)).query(new[k].reshape(-1, 3))[0].max() < 1e-5
        assert abs(_area(new[k]) - _area(old[k])) < 1e-6 * max(_area(old[k]), 1e-9) + 1e-9


def test_the_texture_coordinates_follow_the_kept_vertices(tmp_path):
    src = os.path.join(VISUAL, "link5.obj")  # one group with a varied palette (std 35 of 255)
    write_decimated_obj(src, str(tmp_path / "link5.obj"), 0.1)
    _, _, uv, groups = _read_obj(str(tmp_path / "link5.obj"))
    textured = [g for g in groups if g.v and (np.asarray(g.vt) >= 0).all()]
    assert textured and len(uv) == sum(len(np.unique(np.asarray(g.v))) for g in textured)
    assert np.all((uv >= -1e-6) & (uv <= 1 + 1e-6))


def test_the_cached_directory_is_built_once_with_the_library_files(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    d1 = decimated_visual_dir(VISUAL, 0.1)
    mtime = os.path.getmtime(os.path.join(d1, "link1.obj"))
    assert decimated_visual_dir(VISUAL, 0.1) == d1 and os.path.getmtime(os.path.join(d1, "link1.obj")) == mtime
    assert sorted(os.listdir(d1)) == sorted(os.listdir(VISUAL))  # materials and the texture beside the meshes
    assert decimated_visual_dir(VISUAL, 0.2) != d1


def test_a_face_that_is_not_a_triangle_is_refused(tmp_path):
    bad = tmp_path / "quad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    with pytest.raises(ValueError, match="4 corners"):
        write_decimated_obj(str(bad), str(tmp_path / "out.obj"), 0.5)
