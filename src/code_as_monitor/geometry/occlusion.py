"""The robot as an occluder: how much of a part the robot's own body hides, and whether a remembered estimate of
a part still agrees with what the views show.

A robot's arm between a part and the cameras is common (an arm that has just lifted a block above a tower, a
hand over a drawer). The painter's box fit (:mod:`~.solid`, :mod:`~.carve`) then rests on the few pixels the arm
leaves, and its hidden sides are carved through the space the arm hides: the element can be centimetres off
while looking well supported. Two measures here let the painter tell such an element and do better:

- :func:`robot_hidden_fraction`: of the pixels the part's (carved) box covers in the views, the fraction where the
  robot (its mask, from a segmenter that knows the robot or a rendering of its model at its joint state) is in
  front of it. An element over :data:`ROBOT_HIDDEN_WEAK` was painted mostly through the robot.
- :func:`robot_hidden_points`: the same for a cloud (a remembered estimate of a part no view sees now), over the
  projections that do not fall on the part's own visible pixels.
- :func:`contradiction`: how much a remembered estimate of the part (its cloud where it is believed to be now) is
  contradicted by the current views: its points where a view sees *past* them (a depth reading further than the
  point, on a pixel that is not the part's own), and the part's currently visible points that lie outside the
  remembered solid. An object that moved leaves its old place seen through, or shows where it was not.

World frame, metres; images (H, W); cameras :class:`~code_as_monitor.core.camera.CameraModel`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import ROBOT_HIDDEN_WEAK
from code_as_monitor.geometry.solid import Box

SEEN_THROUGH_TOL = 0.01
"""Metres: a view sees past a point when its depth reading is at least this much further than the point."""
OUTSIDE_TOL = 0.005
"""Metres: a visible point lies outside a remembered solid when it is further than this outside its bounds."""


@dataclass(frozen=True)
class OccluderView:
    """One view for occlusion measures: ``depth`` (H, W) metres, ``camera``, ``robot`` (H, W) bool the robot's own
    pixels (None: this view cannot tell the robot), ``own`` (H, W) bool the part's (or its object's) pixels."""

    depth: np.ndarray
    camera: CameraModel
    robot: np.ndarray | None = None
    own: np.ndarray | None = None


def box_corners(box: Box) -> np.ndarray:
    """(8, 3) world corners of ``box``."""
    lo, hi = box.lo, box.hi
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return c @ box.axes


def _footprint(corners: np.ndarray, camera: CameraModel, shape: tuple[int, int]) -> tuple[np.ndarray, float] | None:
    """(pixel rows, cols) of the convex hull of ``corners`` (8, 3) projected into ``camera`` and the farthest
    corner's depth; None when a corner is behind the camera or the hull misses the image."""
    import cv2

    uv, z = camera.project(corners)
    if not np.all(z > 1e-6) or not np.all(np.isfinite(uv)):
        return None
    H, W = shape
    lo, hi = np.floor(uv.min(axis=0)).astype(int), np.ceil(uv.max(axis=0)).astype(int)
    if hi[0] < 0 or hi[1] < 0 or lo[0] >= W or lo[1] >= H or (hi - lo).max() > 4 * max(H, W):
        return None
    # filled in the window of the image the hull's bounds cover (integer vertices: the same pixels as filling the
    # whole image), so a small box does not pay for clearing and scanning every pixel
    r0, c0 = max(0, int(lo[1]) - 1), max(0, int(lo[0]) - 1)
    r1, c1 = min(H, int(hi[1]) + 2), min(W, int(hi[0]) + 2)
    img = np.zeros((max(0, r1 - r0), max(0, c1 - c0)), dtype=np.uint8)
    hull = cv2.convexHull(np.rint(uv).astype(np.int32) - np.array([c0, r0], dtype=np.int32))
    cv2.fillConvexPoly(img, hull, 1)
    rows, cols = np.nonzero(img)
    return (rows + r0, cols + c0), float(z.max())


def robot_hidden_fraction(box: Box, views: Sequence[OccluderView]) -> float:
    """Fraction (0..1) of the pixels ``box`` covers in the views (its projected outline, summed over the views that
    have a robot mask) where the robot is in front of it: a robot pixel (not one of ``own``) whose depth is nearer
    than the box's far side. 0 when no view has a robot mask or the box projects into none of them."""
    corners = box_corners(box)
    covered = total = 0
    for v in views:
        if v.robot is None:
            continue
        fp = _footprint(corners, v.camera, v.robot.shape)
        if fp is None:
            continue
        (r, c), zfar = fp
        if len(r) == 0:
            continue
        d = np.asarray(v.depth, dtype=np.float64)[r, c]
        front = v.robot[r, c] & np.isfinite(d) & (d > 0) & (d < zfar)
        if v.own is not None:
            front &= ~v.own[r, c]
        covered += int(front.sum())
        total += len(r)
    return covered / total if total else 0.0


def robot_hidden_points(points: np.ndarray, views: Sequence[OccluderView]) -> float:
    """How much of a remembered part the robot (or what it holds) hides now: of the in-image projections of
    ``points`` (N, 3) in the views that have a robot mask, leaving out those on ``own`` (the part itself, seen now),
    the fraction (0..1) that falls on a robot pixel nearer than the point.

    A projection on the part's own visible pixels is explained by the part (it does not hide itself, also when its
    object is held and so masked as the robot): it tells nothing about the rest, so it counts neither way. A book
    held upright shows a camera above only its spine's top end, and the whole remembered spine projects onto that end
    there; counted as not hidden, those projections brought the share to 0.25 instead of 0.48 (stow-book (c)
    2125215470, whose fresh spine, fitted across its end, then read the book tilted 87 degrees). 0 when every
    projection is on the part (nothing left for the robot to hide)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    hid = n = 0
    for v in views:
        if v.robot is None or not len(P):
            continue
        ui, vi, z = _pixels(P, v)
        if v.own is not None and len(ui):
            rest = ~v.own[vi, ui]
            ui, vi, z = ui[rest], vi[rest], z[rest]
        if not len(ui):
            continue
        d = np.asarray(v.depth, dtype=np.float64)[vi, ui]
        hid += int((v.robot[vi, ui] & np.isfinite(d) & (d > 0) & (d < z)).sum())
        n += len(ui)
    return hid / n if n else 0.0


def ball_pixel_box(camera: CameraModel, centre: np.ndarray, radius: float, shape: tuple[int, ...],
                   margin_px: int = 2) -> tuple[int, int, int, int] | None:
    """``(row0, row1, col0, col1)``, inclusive: a box of an (H, W) image holding every pixel whose ray meets the ball
    of ``radius`` metres around ``centre`` (3,) world, so every pixel whose lifted point can lie in it (a lifted point
    lies on its pixel's ray, and the ball's projection lies inside that of its bounding cube); ``margin_px`` more on
    each side. None when the cube is not wholly in front of the camera (any pixel may then). Empty (row0 > row1 or
    col0 > col1) when the ball projects outside the image."""
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    corners = c + radius * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
    uv, z = camera.project(corners)
    if not (np.all(z > 1e-6) and np.all(np.isfinite(uv))):
        return None
    H, W = int(shape[0]), int(shape[1])
    c0, c1 = int(np.floor(uv[:, 0].min())) - margin_px, int(np.ceil(uv[:, 0].max())) + margin_px
    r0, r1 = int(np.floor(uv[:, 1].min())) - margin_px, int(np.ceil(uv[:, 1].max())) + margin_px
    return max(r0, 0), min(r1, H - 1), max(c0, 0), min(c1, W - 1)


def any_point_near(masks: Sequence[np.ndarray], boxes: Sequence[tuple[int, int, int, int]], lifted: Sequence,
                   centre: np.ndarray, radius: float) -> bool:
    """Whether a point lifted from ``masks`` (one (H, W) mask per view) lies within ``radius`` metres of ``centre``
    (3,) world, lifting only the masks' pixels inside ``boxes`` (:func:`ball_pixel_box` of that ball, one per view:
    every such point's pixel is in them); ``lifted``: per view, a
    :class:`~code_as_monitor.geometry.backproject.LiftedView` (its window form of ``points``)."""
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    for m, (r0, r1, c0, c1), lv in zip(masks, boxes, lifted):
        window = np.asarray(m, dtype=bool)[r0:r1 + 1, c0:c1 + 1]
        P = lv.points(window, corner=(r0, c0)) if window.any() else np.empty((0, 3))
        if len(P) and float(np.min(np.linalg.norm(P - c, axis=1))) <= radius:
            return True
    return False


def _pixels(P: np.ndarray, v: OccluderView) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cols, rows, depths along the axis) of the points of ``P`` (N, 3) that project into ``v``'s image."""
    uv, z = v.camera.project(P)
    H, W = v.depth.shape
    u, w = np.rint(uv[:, 0]), np.rint(uv[:, 1])
    ok = (z > 1e-6) & np.isfinite(u) & np.isfinite(w) & (u >= 0) & (u < W) & (w >= 0) & (w < H)
    return u[ok].astype(np.int64), w[ok].astype(np.int64), z[ok]


def _grow_one_pixel(mask: np.ndarray) -> np.ndarray:
    """(H, W) bool: ``mask`` grown by one pixel in the 8 directions."""
    out = mask.copy()
    out[1:, :] |= mask[:-1, :]
    out[:-1, :] |= mask[1:, :]
    g = out.copy()
    out[:, 1:] |= g[:, :-1]
    out[:, :-1] |= g[:, 1:]
    return out


def contradiction(cloud: np.ndarray, centre: np.ndarray, visible: np.ndarray,
                  views: Sequence[OccluderView]) -> tuple[float, float]:
    """How much the views contradict a remembered estimate of a part.

    Args:
        cloud: (M, 3) the part's remembered points (its visible skin when it was painted), moved to where the part
            is believed to be now.
        centre: (3,) its remembered centre there; the remembered solid is the cloud and its reflection through the
            centre (a block's hidden faces mirror its seen ones), as an axis-aligned extent.
        visible: (N, 3) the part's points the views show now (may be empty).
        views: the current views, with ``own`` the part's (or its object's) mask.
    Returns:
        (seen_through, outside): the fraction of the cloud's in-image projections, over views, where the depth reads
        at least :data:`SEEN_THROUGH_TOL` past the point on a pixel not the part's own nor next to one (a thin part's
        skin seen edge-on projects onto its silhouette's border, known to a pixel); the fraction of ``visible``
        further than :data:`OUTSIDE_TOL` outside the remembered solid (0 when nothing is visible).
    """
    P = np.asarray(cloud, dtype=np.float64).reshape(-1, 3)
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    seen = n = 0
    for v in views:
        ui, vi, z = _pixels(P, v)
        if not len(ui):
            continue
        d = np.asarray(v.depth, dtype=np.float64)[vi, ui]
        past = np.isfinite(d) & (d > z + SEEN_THROUGH_TOL)
        if v.own is not None:  # a silhouette is known to a pixel: a point by the part's own pixels is not past it
            past &= ~_grow_one_pixel(np.asarray(v.own, dtype=bool))[vi, ui]
        seen += int(past.sum())
        n += len(ui)
    V = np.asarray(visible, dtype=np.float64).reshape(-1, 3)
    outside = 0.0
    if len(V) and len(P):
        S = np.vstack([P, 2.0 * c - P])
        lo, hi = S.min(axis=0) - OUTSIDE_TOL, S.max(axis=0) + OUTSIDE_TOL
        out_of = np.any(np.less(V, lo) | np.greater(V, hi), axis=1)
        outside = float(np.mean(out_of))
    return (seen / n if n else 0.0), outside


__all__ = [
    "OUTSIDE_TOL",
    "ROBOT_HIDDEN_WEAK",
    "SEEN_THROUGH_TOL",
    "OccluderView",
    "any_point_near",
    "ball_pixel_box",
    "box_corners",
    "contradiction",
    "robot_hidden_fraction",
    "robot_hidden_points",
]
