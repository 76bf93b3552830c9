"""Constraint elements from masks and depth: elements that stand for the object, not its visible skin.

Pipeline of :func:`build_element` (all clouds (N, 3), world frame, metres):

1. the part's cloud over all views (:mod:`~.part_cloud`: lift, fuse, downsample, filter, dense clusters);
2. an oriented box fitted to it, its hidden sides carved through the space no view sees
   (:mod:`~.solid`: a face's normal and a second face or the outline give the axes; the visible faces give the
   extents; a side no view sees past grows until a view sees past it or it meets another surface or the
   support plane);
3. the element points from the box, by kind (paper Sec. 3.2: a point, 2 points for a line, 3-4 for a surface):

   - point (1): the box centre (a solid's centre, a bar's centre, a rim's centre);
   - line (2): the box's longest axis through the centre, from end to end, oriented so that its
     largest-magnitude component is positive;
   - surface (4): the plane through the centre across the box's thinnest observed axis (the part keeps its
     observed thickness: a surface's plane is the middle of what is seen of it); its points are the corners of
     the box's section in that plane (one per 2 x 2 element voxel, as in the paper), in boundary order
     (counter-clockwise seen from the normal's side, the normal oriented to have z >= 0, as
     :func:`~.helpers.normal` does).

Without views (:func:`fit_element_points`), step 2 keeps the observed box.

Every element built from masks carries its cloud (capped at ``MAX_CLOUD_POINTS``) and an
:class:`~code_as_monitor.core.elements.ElementSupport` (points, views, the box residual, extents, assumed
sides and the uncertainty they leave, and the fraction of its box the robot hides when the views carry robot
masks: :mod:`~.occlusion`).
End-effector elements skip all this: :func:`ee_element` builds them from forward kinematics.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from code_as_monitor.core.camera import validate_rigid
from code_as_monitor.core.elements import MAX_CLOUD_POINTS, Element, ElementKind, ElementSpec, ElementSupport, color_for
from code_as_monitor.core.errors import ElementError, GeometryError
from code_as_monitor.geometry.backproject import DEFAULT_MAX_DEPTH, backproject_mask
from code_as_monitor.geometry.carve import CarveView, behind_siblings, carve, face_alone, open_direction, sibling_free
from code_as_monitor.geometry.fusion import voxel_downsample
from code_as_monitor.geometry.occlusion import OccluderView, robot_hidden_fraction
from code_as_monitor.geometry.part_cloud import (
    MIN_FINE_VOXEL,
    Observation3D,
    cap_cloud,
    dense_clusters,
    fine_voxel_size,
    fuse_part,
    mask_cloud,
    part_cloud,
)
from code_as_monitor.geometry.solid import ELONGATED, Box, fit_box
from code_as_monitor.geometry.support import SupportPlane

__all__ = [
    "MIN_FINE_VOXEL", "VOXEL_DIVISIONS", "Observation3D", "build_element", "build_element_from_clouds", "cap_cloud",
    "ee_element",
    "element_points", "element_voxel_size", "fine_voxel_size", "fit_element_points", "mask_cloud", "part_cloud",
]

VOXEL_DIVISIONS: dict[ElementKind, tuple[int, int, int]] = {
    ElementKind.POINT: (1, 1, 1),
    ElementKind.LINE: (2, 1, 1),
    ElementKind.SURFACE: (2, 2, 1),
}
"""Element voxels per axis of the element's own frame (principal axes; for a surface the last axis
is the plane normal): the occupied space is divided into this many voxels, one representative each."""


def element_voxel_size(points: np.ndarray, kind: ElementKind | str) -> np.ndarray:
    """(3,) element-voxel edge lengths (metres) along the element frame's axes for ``kind``.

    The element frame is the cloud's principal axes (largest spread first); the occupied extent along
    each axis is divided by :data:`VOXEL_DIVISIONS` of the kind.
    """
    kind = ElementKind.parse(kind)
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    _, axes = _principal_axes(P)
    s = (P - P.mean(axis=0)) @ axes.T
    extent = s.max(axis=0) - s.min(axis=0) if len(P) else np.zeros(3)
    return extent / np.array(VOXEL_DIVISIONS[kind], dtype=np.float64)


def _principal_axes(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid (3,) and principal axes (3, 3), one per row, largest spread first."""
    c = P.mean(axis=0) if len(P) else np.zeros(3)
    if len(P) < 2:
        return c, np.eye(3)
    X = P - c
    _, V = np.linalg.eigh(X.T @ X)  # ascending eigenvalues of the 3x3 scatter matrix
    return c, V[:, ::-1].T


def _orient(d: np.ndarray) -> np.ndarray:
    """Flip the direction ``d`` (3,) so that its largest-magnitude component is positive."""
    return -d if d[int(np.argmax(np.abs(d)))] < 0 else d


def _surface_points(Q: np.ndarray, box: Box, thin: int) -> np.ndarray:
    """The 4 corners (4, 3) of the box's section through its centre across axis ``thin``, counter-clockwise
    seen from the side the plane's normal (z >= 0) points to."""
    j, k = [a for a in range(3) if a != thin]
    ext = box.extent
    if min(ext[j], ext[k]) < 1e-6:
        raise ElementError(f"cannot fit a surface: the {len(Q)} points are collinear")
    n = box.axes[thin] if box.axes[thin][2] >= 0 else -box.axes[thin]
    c = box.centre
    uj, uk = box.axes[j] * ext[j] / 2.0, box.axes[k] * ext[k] / 2.0
    pts = np.stack([c + uj + uk, c - uj + uk, c - uj - uk, c + uj - uk])
    ang = np.arctan2((pts - c) @ np.cross(n, box.axes[j]), (pts - c) @ box.axes[j])
    return pts[np.argsort(ang)]


def element_points(Q: np.ndarray, box: Box, kind: ElementKind, voxel: float, thin: int | None = None) -> np.ndarray:
    """The element's points (k, 3) world metres from a part's cloud ``Q`` (M, 3) and its box."""
    if kind is ElementKind.POINT:
        return box.centre[None]
    ext = box.extent
    if kind is ElementKind.LINE:
        a = int(np.argmax(ext))
        if ext[a] < 1e-6:
            raise ElementError(f"cannot fit a line: the {len(Q)} points coincide")
        d = _orient(box.axes[a])
        return np.stack([box.centre - ext[a] / 2.0 * d, box.centre + ext[a] / 2.0 * d])
    if len(Q) < 3:
        raise ElementError(f"cannot fit a surface through {len(Q)} point(s)")
    return _surface_points(Q, box, int(np.argmin(ext)) if thin is None else thin)


def _prepare(points: np.ndarray, kind: ElementKind | str, voxel_size: float | None) -> tuple[np.ndarray, float]:
    kind = ElementKind.parse(kind)
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ElementError(f"points must be (N, 3), got shape {P.shape}")
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) == 0:
        raise ElementError(f"cannot fit a {kind.value}: no finite points")
    vs = fine_voxel_size(P) if voxel_size is None else float(voxel_size)
    Q, _ = voxel_downsample(P, vs)
    return dense_clusters(Q, vs), vs


def fit_element_points(
    points: np.ndarray, kind: ElementKind | str, voxel_size: float | None = None
) -> np.ndarray:
    """The element's points from a part's cloud alone (no views: the observed box, nothing carved).

    Args:
        points: (N, 3) world frame, metres (fused, ideally outlier-filtered); non-finite rows ignored.
        kind: point | line | surface (str or :class:`ElementKind`).
        voxel_size: fine downsampling voxel in metres (default :func:`fine_voxel_size`).
    Returns:
        (k, 3) world, metres: k = 1 (the box centre), 2 (line: the ends of the box's longest axis), 3 or 4
        (surface: points spanning the plane through the centre, in boundary order).
    Raises:
        ElementError: unknown kind, no points, or degenerate geometry for the kind.
    """
    kind = ElementKind.parse(kind)
    Q, vs = _prepare(points, kind, voxel_size)
    return element_points(Q, fit_box(Q, vs), kind, vs)


LINE_MIN_ASPECT = float(np.sqrt(ELONGATED))
"""What the points show of a line's part must be at least this many times as long along the line as across it (2:
the spans' ratio of :data:`~code_as_monitor.geometry.solid.ELONGATED`, the outline rule's "elongated") for the views
to show its direction (:func:`seen_lengthwise`)."""


def seen_lengthwise(box: Box) -> bool:
    """Whether the points of the carved ``box`` show the part long along its longest axis, a line's direction: the
    observed box (the carved one less its growth) at least :data:`LINE_MIN_ASPECT` times as long along that axis as
    along either other one.

    A stub does not (a book stood in its shelf, seen by the top 3 cm of its 20 cm spine: 29 x 24 x 7 mm): its frame
    lies wherever its outline and the depth noise put it, 8-22 degrees off under 2 mm of noise, and carving then
    grows it along that frame (to 85 mm behind the cover, 8 degrees off, in one draw). Such a line is weak
    (``ElementSupport.direction_seen``), however long its carved box."""
    seen = box.extent - box.grown.sum(axis=0)
    a = int(np.argmax(box.extent))
    return bool(seen[a] >= LINE_MIN_ASPECT * max(float(seen[b]) for b in range(3) if b != a))


def fit_part(
    Q: np.ndarray, voxel: float, kind: ElementKind, views: Sequence[CarveView],
    support: SupportPlane | None = None, compact: bool = True,
) -> tuple[np.ndarray, Box]:
    """Element points (k, 3) and the carved box of a part's cloud ``Q`` (M, 3) seen in ``views``; ``compact``:
    ``Q`` is a whole object (see :func:`~.carve.carve`)."""
    seen = fit_box(Q, voxel) if support is None else fit_box(Q, voxel, noise=support.noise, up=support.normal)
    thin = int(np.argmin(seen.extent))
    grow = [a for a in range(3) if not (kind is ElementKind.SURFACE and a == thin)]
    box = carve(seen, views, support, grow, points=Q, compact=compact)
    # None without sibling parts, or when neither reader below could use it (not a line, no axis one face alone)
    free = sibling_free(seen, views, support, grow, Q, compact) \
        if kind is ElementKind.LINE or any(face_alone(seen, a, Q) for a in grow) else None
    if kind is ElementKind.LINE:  # a line whose direction only its siblings' surfaces decide is weak
        box = open_direction(seen, box, free, grow)
    box = behind_siblings(seen, box, free, Q)  # how far a face may go on behind them: uncertainty, not weakness
    return element_points(Q, box, kind, voxel, thin), box


def build_element(
    id: int,
    spec: ElementSpec,
    observations: Sequence[Observation3D],
    max_depth: float = DEFAULT_MAX_DEPTH,
    support: SupportPlane | None = None,
) -> Element:
    """Build the element ``spec`` from its masks in one or more views.

    Args:
        id: element id (the number drawn on the images); also picks the colour.
        spec: what to abstract (object, part, kind).
        observations: ``(mask (H, W) bool, depth (H, W) metres, camera)`` per view; a view where the
            part is not visible (empty mask or no valid depth) adds no points but still carves free space.
        max_depth: metres; depth beyond is missing.
        support: optional support plane (:func:`~.support.support_plane`): the part's hidden sides never grow
            below it; its normal is tried as a box axis and its noise estimate sets the tolerances.
    Returns:
        The element, points in the world frame, owner ``(spec.obj, spec.part)``, with its cloud and support.
    Raises:
        ShapeMismatchError, NoValidDepthError, ElementError (degenerate geometry for the kind).
    """
    clouds = [backproject_mask(m, d, cam, max_depth, allow_empty=True) for m, d, cam in observations]
    views = [CarveView(np.asarray(m, dtype=bool), d, cam) for m, d, cam in observations]
    return build_element_from_clouds(id, spec, clouds, views, support)


def build_element_from_clouds(
    id: int,
    spec: ElementSpec,
    clouds: Sequence[np.ndarray],
    views: Sequence[CarveView],
    support: SupportPlane | None = None,
) -> Element:
    """:func:`build_element` from the part's points already lifted per view (``clouds``: (N_i, 3) world
    metres, one per view, in the order of ``views``, whose masks are the part's)."""
    P, vs, nviews = fuse_part(clouds, [v.camera.name for v in views], f"element {spec.name!r}")
    Q = dense_clusters(P, vs)
    if len(Q) == 0:  # every point was isolated (a part a single view sees as a few scattered pixels)
        raise ElementError(f"element {spec.name!r} ({spec.obj}/{spec.part or '*'}): no points left to fit after "
                           f"dropping isolated ones ({len(P)} fused)")
    try:
        pts, box = fit_part(Q, vs, spec.kind, views, support, compact=not spec.part)
    except ElementError as exc:
        raise ElementError(f"element {spec.name!r} ({spec.obj}/{spec.part or '*'}): {exc}") from None
    ext = np.sort(box.extent)[::-1]
    hidden = robot_hidden_fraction(box, [OccluderView(v.depth, v.camera, v.robot, _own(v)) for v in views]) \
        if any(v.robot is not None for v in views) else 0.0
    sup = ElementSupport(len(Q), int(nviews), box.residual(Q), float(ext[0] / 2.0),
                         (float(ext[0]), float(ext[1]), float(ext[2])), int((box.hidden | box.assumed).sum()),
                         robot_hidden=hidden, uncertainty=box.uncertainty,
                         direction_seen=spec.kind is not ElementKind.LINE or seen_lengthwise(box))
    return Element(id, spec.name, spec.kind, pts, (spec.obj, spec.part), color_for(id),
                   cloud=cap_cloud(Q, MAX_CLOUD_POINTS, vs), support=sup)


def _own(view: CarveView) -> np.ndarray:
    """(H, W) bool: the part's object in ``view`` (its mask and its sibling parts)."""
    return view.mask if view.siblings is None else view.mask | view.siblings


def ee_element(
    id: int,
    name: str,
    pose_or_point: np.ndarray,
    owner: tuple[str, str] = ("robot", "tip"),
    tip_offset: np.ndarray | None = None,
    axis_length: float | None = None,
    axis: int = 2,
) -> Element:
    """An end-effector element straight from forward kinematics (no segmentation).

    Args:
        id: element id.
        name: legend name.
        pose_or_point: (4, 4) end-effector pose in the world, or a (3,) world tool-tip point.
        owner: (object, part) it stands for.
        tip_offset: (3,) tool tip in the end-effector frame, metres (default: the frame origin).
        axis_length: when given (metres, > 0), build a line along the tool axis instead of a point:
            from ``tip - axis_length * a`` to ``tip``, ``a`` being the pose's column ``axis``, so the
            line's direction points towards the tip. Needs a pose.
        axis: which end-effector axis is the tool axis (0 x, 1 y, 2 z).
    Raises:
        GeometryError: not a (3,) point nor a rigid (4, 4) pose.
        ElementError: a line asked for from a bare point, or a non-positive ``axis_length``.
    """
    a = np.asarray(pose_or_point, dtype=np.float64)
    if a.shape == (3,) or a.shape == (1, 3):
        if axis_length is not None:
            raise ElementError(f"element {name!r}: a tool-axis line needs a (4, 4) pose, got a point")
        return Element.point(id, name, a.reshape(3), owner)
    if a.shape != (4, 4):
        raise GeometryError(f"element {name!r}: expected a (3,) point or a (4, 4) pose, got shape {a.shape}")
    T = validate_rigid(a, f"pose of {name!r}")
    off = np.zeros(3) if tip_offset is None else np.asarray(tip_offset, dtype=np.float64).reshape(3)
    tip = T[:3, :3] @ off + T[:3, 3]
    if axis_length is None:
        return Element.point(id, name, tip, owner)
    if not axis_length > 0:
        raise ElementError(f"element {name!r}: axis_length must be > 0, got {axis_length!r}")
    if axis not in (0, 1, 2):
        raise ElementError(f"element {name!r}: axis must be 0, 1 or 2, got {axis!r}")
    return Element.line(id, name, tip - axis_length * T[:3, axis], tip, owner)
