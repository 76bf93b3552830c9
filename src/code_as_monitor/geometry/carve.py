"""Carving a part's hidden sides: push each side of its observed box outwards through space no view sees.

Step 3 of :mod:`code_as_monitor.geometry.solid` (whose docstring gives the whole method): a side no view sees
past may extend further than the points show (the back of a block seen only from the front; a block under
another one; a book inside a shelf). Each side is pushed outwards slab by slab while the slab stays hidden in
every view (:func:`carve`), never below the support plane (:mod:`code_as_monitor.geometry.support`).

World frame, metres; ``axes`` (3, 3) hold one unit axis per row.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.geometry.solid import Box
from code_as_monitor.geometry.stats import percentile
from code_as_monitor.geometry.support import SupportPlane

CARVE_GRID = 4
"""Samples per side of a slab (a CARVE_GRID x CARVE_GRID grid over the central part of the face)."""
CARVE_INSET = 0.02
"""Fraction of each face dimension left out at its borders when sampling a slab."""
PIXEL_MARGIN = 1.0
"""Pixels (of the coarsest view at the part) left out at a face's borders too: a mask's silhouette is only
known to a pixel, so a sample nearer the border than that may fall just outside the part's mask."""
CARVE_STOP = 0.1
"""A slab stops the growth when at least this fraction of its samples (and at least 2) is not hidden."""
MIN_TOL = 0.003
"""Metres: the least depth tolerance for "on a surface" (the rendered depth's own precision is far finer)."""
SHELL = 0.01
"""Metres: a sample less than this behind another surface is taken to be inside that object."""
SUPPORT_SLACK = 0.0005
"""Metres: how far below the support plane a slab sample may lie before the plane stops the growth (half the
:data:`FINE_STEP`). The plane is the median of thousands of table points, far more precise than one reading: with
the depth tolerance here (3 mm) a block's bottom grew 2-3 mm into the table, its centre 1-1.5 mm low, and a 2 cm
block's carved height made it look longer than it was seen (an assumed side: weak)."""
FINE_STEP = 0.001
"""Metres: the slab step of the final search (the growth is within this of the first blocked slab)."""
COARSE_SLABS = 16
"""The first search divides the growth limit into at most this many slabs (at least ``FINE_STEP`` thick)."""
GROW_LIMIT = 2.0
"""A side grows at most this many times the part's largest observed extent; one that gets there unbounded is
hidden from every view, and the part is then taken to be as deep as the smaller of its other two extents."""
FACE_ALONE = 0.25
"""An axis along which the points span less than this fraction of the smaller of the other two extents (plus the
depth noise's own span, :data:`NOISE_SPAN`) is seen on one face alone (a face's points span only the depth noise
along its normal; a solid seen on two faces spans its whole extent): its depth is then the compact-solid
assumption, bounded by the face's interior carving."""
NOISE_SPAN = 3.29
"""The central 90 % of a Gaussian spans this many standard deviations (2 x 1.645): what a face's points span along
its normal from the depth noise alone (``Box.noise``), the span :func:`_spread` measures."""




@dataclass(frozen=True)
class CarveView:
    """One view for carving: ``mask`` (H, W) bool of the part, ``depth`` (H, W) metres, ``camera``, and
    optionally ``siblings`` (H, W) bool, the same object's other parts (a part never grows behind them), and
    ``robot`` (H, W) bool, the robot's own pixels (carving ignores it; it measures how much of the part the robot
    hides: :func:`~.occlusion.robot_hidden_fraction`)."""

    mask: np.ndarray
    depth: np.ndarray
    camera: CameraModel
    siblings: np.ndarray | None = None
    robot: np.ndarray | None = None
    behind_siblings: bool = False  # the part may go on behind its siblings' surfaces (:func:`open_direction`)


_UNIT_GRIDS: dict[int, np.ndarray] = {}


def _face_samples(box: Box, axis: int, n: int, inset: float, margin: float = 0.0) -> np.ndarray:
    """(n*n, 3) coordinates (along the box axes) of a grid over the central part of the face at ``axis``'s hi
    end, ``inset`` (fraction) and at least ``margin`` metres in from its borders, never past its middle; the
    caller moves them along ``axis``."""
    j, k = (1, 2) if axis == 0 else (0, 2) if axis == 1 else (0, 1)
    ext = box.hi - box.lo
    g = _UNIT_GRIDS.get(n)
    if g is None:
        t = np.linspace(-0.5, 0.5, n)
        g = _UNIT_GRIDS[n] = np.stack(np.meshgrid(t, t), -1).reshape(-1, 2)
    S = np.zeros((n * n, 3))
    for col, a in ((0, j), (1, k)):
        keep = 1.0 - 2.0 * min(0.5, max(inset, margin / max(ext[a], 1e-9)))  # the central fraction sampled
        S[:, a] = (box.lo[a] + box.hi[a]) / 2.0 + g[:, col] * keep * ext[a]
    return S


def carve(box: Box, views: Sequence[CarveView], support: SupportPlane | None = None,
          grow_axes: Sequence[int] = (0, 1, 2), max_grow: float | None = None,
          points: np.ndarray | None = None, compact: bool = True) -> Box:
    """Push the box's hidden sides outwards through space no view sees (step 3 of the module docstring).

    Args:
        box: the observed box (from :func:`fit_box`).
        views: the part's views (mask, depth, camera).
        support: optional support plane (:func:`~.support.support_plane`); nothing grows below it.
        grow_axes: which axes may grow (a surface keeps its observed thickness).
        max_grow: metres; the most a side may grow (default: :data:`GROW_LIMIT` x the largest observed extent).
        points: optional (N, 3) world metres, the part's cloud the box was fitted to: whether its thinnest axis
            is seen on one face alone is judged on the central 90 % of the points along it (a few grazing points
            on a side face do not make a second face), else on the box's extent.
        compact: the cloud is a whole object, a solid: a face seen alone gets a compact solid's depth (see
            :func:`_assume_depth`). False for a part, which may be a face by nature (a box's top, a cover).
    Returns:
        A new box with ``grown`` and ``hidden`` filled in.
    """
    ext = box.extent
    cap = GROW_LIMIT * float(ext.max()) if max_grow is None else float(max_grow)
    out = Box(box.axes.copy(), box.lo.copy(), box.hi.copy(), box.noise)
    if cap <= 0 or not views:
        return out
    tol = max(MIN_TOL, 3.0 * box.noise)
    step = max(FINE_STEP, cap / COARSE_SLABS)
    K = int(np.ceil(cap / step))
    sides = [(a, sgn) for a in grow_axes for sgn in (-1, 1)]
    offsets = step * np.arange(1, K + 1)
    coarse = _slabs_blocked(box, views, support, tol, [(a, sgn, offsets) for a, sgn in sides])
    fine_jobs, grown = [], []
    for (a, sgn), bad in zip(sides, coarse):
        first = int(np.argmax(bad)) if bad.any() else K
        lo_ok = 0.0 if first == 0 else float(offsets[first - 1])
        grown.append(lo_ok)
        out.hidden[1 if sgn > 0 else 0, a] = first == K
        if first < K and step > FINE_STEP:  # refine between the last free slab and the first blocked one
            fine_jobs.append((len(grown) - 1, a, sgn, lo_ok + FINE_STEP * np.arange(1, int(step / FINE_STEP))))
    if fine_jobs:
        fine = _slabs_blocked(box, views, support, tol, [(a, sgn, offs) for _, a, sgn, offs in fine_jobs])
        for (k, _, _, offs), bad in zip(fine_jobs, fine):
            first = int(np.argmax(bad)) if bad.any() else len(offs)
            if first > 0:
                grown[k] = float(offs[first - 1])
    for (a, sgn), g in zip(sides, grown):
        out.grown[1 if sgn > 0 else 0, a] = g
    out.room[out.hidden] = cap
    for a in range(3):  # unbounded sides: the part is as deep as the smaller of its other two extents
        if out.hidden[:, a].any():
            others = [ext[b] for b in range(3) if b != a]
            missing = max(0.0, min(others) - ext[a] - out.grown[~out.hidden[:, a], a].sum())
            out.grown[out.hidden[:, a], a] = missing / int(out.hidden[:, a].sum())
    a = int(np.argmin(ext))  # the part's thinnest axis; a surface's (its normal) is not grown: nothing to assume
    if compact and a in grow_axes and not out.hidden[:, a].any():  # a compact solid's depth: see _assume_depth
        prior = min(ext[b] for b in range(3) if b != a)
        if face_alone(box, a, points):
            _assume_depth(out, ext, a, _interior_room(box, views, support, tol, a, step, K))
        elif ext[a] + out.grown[:, a].sum() > (1.0 + FACE_ALONE) * prior:
            _assume_depth(out, ext, a, out.grown[:, a].copy())
    if compact:
        for b in grow_axes:
            if b != a and not out.hidden[:, b].any():
                _no_new_length(out, box, b)
    out.lo -= out.grown[0]
    out.hi += out.grown[1]
    return out


def _no_new_length(out: Box, box: Box, a: int) -> None:
    """A whole object does not become long along an axis it was not seen long along, in place on ``out``.

    The carving of a side is an upper bound wherever what stopped it was a view seeing past it: behind another
    object's surface (more than :data:`SHELL` behind it) the space may as well be that object's. So a block whose
    top another block covers grows up into that block until some view sees past the upper block's top (the lower
    block of a tower seen from a shoulder: 30 mm, its centre 15 mm high), and the middle block of a tower grows
    down through the lower one to the table (42 mm). When the carving makes axis ``a`` more than
    ``1 + FACE_ALONE`` times the largest other extent, though the points did not show the object long along ``a``,
    ``a`` gets the compact-solid length instead: as long as the largest other extent, between the observed extent
    and the carved one, shared between the two sides in proportion to their growth. Those sides are ``assumed``
    (their growth is the room, for the element's uncertainty). An object seen long along ``a`` (a pen, a stick:
    longer than ``1 + FACE_ALONE`` times its other extents) grows along it as the views allow; one standing on the
    table with its lower part hidden behind another object, not seen long, gets the compact length too, and says
    so (``assumed``)."""
    ext = box.extent
    longest_other = max(ext[b] for b in range(3) if b != a)
    carved = ext[a] + out.grown[:, a].sum()
    if ext[a] > (1.0 + FACE_ALONE) * longest_other or carved <= (1.0 + FACE_ALONE) * longest_other:
        return
    room = out.grown[:, a].copy()
    share = min(max(longest_other - ext[a], 0.0), float(room.sum())) * room / room.sum()
    out.grown[:, a] = share
    out.room[:, a] = room
    out.assumed[:, a] = room > share + FINE_STEP


def _spread(box: Box, a: int, points: np.ndarray | None) -> float:
    """Metres: the span of the central 90 % of ``points`` (N, 3) along ``box.axes[a]`` (the box's extent there
    without points)."""
    if points is None or len(points) < 10:
        return float(box.extent[a])
    s = np.asarray(points, dtype=np.float64) @ box.axes[a]
    lo, hi = percentile(s, [5.0, 95.0])
    return float(hi - lo)


def _interior_room(box: Box, views: Sequence[CarveView], support: SupportPlane | None, tol: float,
                   a: int, step: float, K: int) -> np.ndarray:
    """(2,) metres (lo side, hi side): how far the interior of the face across axis ``a`` may grow as far as the
    views tell (see :func:`_assume_depth`); ``K`` slabs of ``step`` metres, refined to :data:`FINE_STEP`."""
    offsets = step * np.arange(1, K + 1)
    sides = [(a, -1), (a, 1)]
    coarse = _slabs_blocked(box, views, support, tol, [(a, sgn, offsets) for a, sgn in sides], SHELL)
    room = []
    for (a, sgn), bad in zip(sides, coarse):
        first = int(np.argmax(bad)) if bad.any() else K
        lo_ok = 0.0 if first == 0 else float(offsets[first - 1])
        if first < K and step > FINE_STEP:
            offs = lo_ok + FINE_STEP * np.arange(1, int(step / FINE_STEP))
            fine = _slabs_blocked(box, views, support, tol, [(a, sgn, offs)], SHELL)[0]
            k = int(np.argmax(fine)) if fine.any() else len(offs)
            lo_ok = float(offs[k - 1]) if k > 0 else lo_ok
        room.append(lo_ok)
    return np.array(room)


def _assume_depth(out: Box, ext: np.ndarray, a: int, room: np.ndarray) -> None:
    """Give the part's thinnest axis ``a`` the compact-solid depth, in place on ``out``, where the views leave it
    open: when that axis is seen on one face alone (below), or when the carving let it grow deeper than the
    part's other two extents (``room`` is then that growth: a side carved until some view happened to see past
    it, far behind a block whose back a neighbour hides, is an upper bound, not a measurement), by more than
    :data:`FACE_ALONE` of them (less is within what noise and the outline's pixels do to a fully seen solid).

    A face seen alone (the blocks in the middle of a tower, whose neighbours hide their tops and bottoms and whose
    backs face away) bounds nothing behind it: the carving of the whole face stops where a neighbour flush with
    its border begins (another object's surface within :data:`SHELL` of a sample near the border), or where a
    one-pixel-too-wide outline sees past the solid, and it runs on far beyond the solid where a neighbour hides the
    space behind it. What the views do prove is the room the face's *interior* (its samples at least
    :data:`SHELL` in from the face's border, ``rooms``) has before a view sees past it, another surface is within
    :data:`SHELL`, or the support plane is met. The depth is then the compact-solid assumption, as deep as the
    smaller of the other two extents, clamped between the observed depth and the observed depth plus that room,
    shared between the two sides in proportion to their room (the side facing the views has none). Those sides
    are ``assumed``; their room is recorded for the element's uncertainty."""
    r = np.maximum(room, out.grown[:, a])
    if r.sum() <= 0.0:
        return
    prior = min(ext[b] for b in range(3) if b != a)
    share = min(max(prior - ext[a], 0.0), float(r.sum())) * r / r.sum()
    out.grown[:, a] = share
    out.room[:, a] = r
    out.assumed[:, a] = share > FINE_STEP


def _slabs_blocked(box: Box, views: Sequence[CarveView], support: SupportPlane | None, tol: float,
                   jobs: Sequence[tuple[int, int, np.ndarray]], border: float = 0.0) -> list[np.ndarray]:
    """For each job ``(axis, sign, offsets (K,))``: (K,) bool, True where the slab that far beyond that side of
    the box is not hidden (see :func:`carve`); the slab's samples are at least ``border`` metres in from the
    face's border (and one pixel, :data:`PIXEL_MARGIN`)."""
    n = CARVE_GRID
    blocks = []
    margin = max(border, PIXEL_MARGIN * max(_pixel_size(v.camera, box.centre) for v in views))
    for a, sgn, offs in jobs:
        base = _face_samples(box, a, n, CARVE_INSET, margin)
        edge = box.hi[a] if sgn > 0 else box.lo[a]
        S = np.repeat(base[None], len(offs), axis=0)
        S[:, :, a] = edge + sgn * np.asarray(offs)[:, None]
        blocks.append(S.reshape(-1, 3))
    W = np.vstack(blocks) @ box.axes  # world
    bad = np.zeros(len(W), dtype=bool)
    if support is not None:
        bad |= W @ support.normal < support.offset - SUPPORT_SLACK
    for v in views:
        bad |= ~_hidden_in(W, v, tol)
    need = max(2, int(np.ceil(CARVE_STOP * n * n)))
    out, start = [], 0
    for _, _, offs in jobs:
        m = len(offs) * n * n
        out.append(bad[start : start + m].reshape(len(offs), n * n).sum(axis=1) >= need)
        start += m
    return out


def _pixel_size(camera: CameraModel, p: np.ndarray) -> float:
    """Metres one pixel of ``camera`` spans at world point ``p`` (3,) (0 behind the camera)."""
    _, z = camera.project(p[None])
    return max(float(z[0]), 0.0) / float(min(camera.K[0, 0], camera.K[1, 1]))


def _hidden_in(W: np.ndarray, view: CarveView, tol: float) -> np.ndarray:
    """(N,) True where world points ``W`` (N, 3) may belong to the part as far as ``view`` can tell: outside
    its image, without a depth reading, behind (or within ``tol`` of) the part's own surface, or more than
    ``SHELL`` behind a surface of another object (not a sibling part of its own object)."""
    cam = view.camera
    R, t = cam.T_world_cam[:3, :3], cam.T_world_cam[:3, 3]
    pc = (W - t) @ R  # camera frame
    z = pc[:, 2]
    H, Wd = view.depth.shape
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.rint(cam.K[0, 0] * pc[:, 0] / z + cam.K[0, 1] * pc[:, 1] / z + cam.K[0, 2])
        vv = np.rint(cam.K[1, 1] * pc[:, 1] / z + cam.K[1, 2])
    inside = (z > 1e-6) & np.isfinite(u) & np.isfinite(vv) & (u >= 0) & (u < Wd) & (vv >= 0) & (vv < H)
    ok = np.ones(len(W), dtype=bool)
    idx = np.flatnonzero(inside)
    if len(idx) == 0:
        return ok
    ui, vi = u[idx].astype(np.int64), vv[idx].astype(np.int64)
    D = view.depth[vi, ui].astype(np.float64)
    zi = z[idx]
    valid = np.isfinite(D) & (D > 0)
    own = view.mask[vi, ui]
    if view.siblings is not None and view.behind_siblings:
        own = own | view.siblings[vi, ui]
    # the part's own surface at or in front of the sample: it may be inside; another surface: only when the
    # sample lies more than SHELL behind it (closer, it would be inside that other thing); a sibling part's
    # surface: never (the object's other parts are where the part ends)
    ok[idx] = ~valid | np.where(own, zi + tol >= D, zi - max(SHELL, tol) > D)
    if view.siblings is not None and not view.behind_siblings:
        ok[idx] &= ~view.siblings[vi, ui]
    return ok


def sibling_free(observed: Box, views: Sequence[CarveView], support: SupportPlane | None = None,
                 grow_axes: Sequence[int] = (0, 1, 2), points: np.ndarray | None = None,
                 compact: bool = False) -> Box | None:
    """``observed`` carved as if the part's sibling parts bounded nothing (their surfaces taken as its own: it may go on
    right behind them), for :func:`open_direction` and :func:`behind_siblings`; None when no view has siblings."""
    if not any(v.siblings is not None for v in views):
        return None
    return carve(observed, [replace(v, behind_siblings=True) for v in views], support, grow_axes, points=points,
                 compact=compact)


def _reach(free: Box) -> np.ndarray:
    """(2, 3) metres: how far each side of a sibling-free carving may go (the room of a side it left unbounded)."""
    return np.where(free.hidden, free.room, free.grown)


def open_direction(observed: Box, carved: Box, free: Box | None, grow_axes: Sequence[int] = (0, 1, 2)) -> Box:
    """``carved`` (from :func:`carve` of ``observed``) with the sides marked ``assumed`` that leave a line's direction
    open: the sides across its longest axis that, in ``free`` (:func:`sibling_free`, the part carved as if its sibling
    parts bounded nothing), let it run at least as long across as along.

    Carving stops a part at its siblings' surfaces (the object's other parts are where a part ends); that is an
    assumption where the part may go on behind them. A line takes the carved box's longest axis, so when a part is
    seen only by a short end whose rest lies behind its sibling (a book stood in its shelf, its spine on the far side
    of the cover: the views see the spine's 1 x 2.4 cm top alone, and the line lay across the spine, 90 degrees off),
    nothing the views show fixes its direction. Those sides keep their growth (the element does not move) and are
    ``assumed``, their ``room`` the sibling-free growth: the element is weak
    (:meth:`~code_as_monitor.core.elements.ElementSupport.weak`) and its ``uncertainty`` says how far it may reach.
    """
    if free is None:
        return carved
    a = int(np.argmax(carved.extent))
    reach = _reach(free)
    out = replace(carved, assumed=carved.assumed.copy(), room=carved.room.copy())
    for b in grow_axes:  # only the sides across the line can open its direction
        if b == a or observed.extent[b] + reach[:, b].sum() < carved.extent[a]:
            continue
        more = reach[:, b] > carved.grown[:, b] + FINE_STEP
        out.assumed[more, b] = True
        out.room[more, b] = np.maximum(out.room[more, b], reach[more, b])
    return out


def face_alone(box: Box, a: int, points: np.ndarray | None) -> bool:
    """Whether ``box``'s axis ``a`` is seen on one face alone: the points span along it less than
    :data:`FACE_ALONE` of the smaller of the other two extents, plus the depth noise's own span."""
    prior = min(float(box.extent[b]) for b in range(3) if b != a)
    return _spread(box, a, points) < FACE_ALONE * prior + NOISE_SPAN * box.noise


def behind_siblings(observed: Box, carved: Box, free: Box | None, points: np.ndarray | None = None) -> Box:
    """``carved`` (from :func:`carve` of ``observed``) with ``behind`` filled in from ``free`` (:func:`sibling_free`):
    along each axis the part is seen on one face alone, for each side neither hidden nor assumed, how much further
    than its carved growth it could go on behind its siblings' surfaces.

    Carving ends a part where its siblings begin, which is right for most parts (a handle on its drawer's front, a
    lid on its pot: their depth is seen, or bounded by the views) and wrong where the part shows one face and its
    rest lies behind a sibling (a closed drawer: its front panel is all the views see, its tray runs on under the
    cabinet's top; carved, the drawer is its front panel, its centre about 11 cm before the tray's). A part seen on
    one face alone may be a face by nature (a cover, a panel), so the views cannot tell the two apart: the element
    stays where it is painted, not weak, and the room behind the siblings enters its ``uncertainty``
    (:attr:`~code_as_monitor.geometry.solid.Box.uncertainty`). Along an axis the points span, a sibling is where the
    part ends, and nothing is recorded."""
    if free is None:
        return carved
    extra = np.maximum(_reach(free) - carved.grown, 0.0)
    extra[(carved.hidden | carved.assumed) | (extra <= FINE_STEP)] = 0.0
    for a in range(3):
        if not face_alone(observed, a, points):
            extra[:, a] = 0.0
    return replace(carved, behind=extra)


__all__ = ["CarveView", "behind_siblings", "carve", "face_alone", "open_direction", "sibling_free"]
