"""Constraint elements from masks and depth: the paper's element pipeline (Sec. 3.2 and Supp.).

Pipeline of :func:`build_element` (all clouds (N, 3), world frame, metres):

1. back-project every view's mask with its depth (:func:`~.backproject.backproject_mask`) and fuse;
2. voxel-downsample on a fine grid (``fine_voxel_size``: 4 mm, coarser for big parts) so that every
   later stage sees an evenly spread cloud of bounded size, whatever the image resolution;
3. statistical outlier removal (:func:`~.fusion.remove_outliers`);
4. :func:`fit_element_points`: DBSCAN drops the sparse points that survived and splits off debris,
   then the occupied space is divided into element voxels whose size is set by the element kind
   (:data:`VOXEL_DIVISIONS`: 1 voxel for a point, 2 along the principal axis for a line, 2 x 2 over
   the fitted plane for a surface, as in the paper), one representative is picked per voxel and the
   representatives are filtered to the count the kind needs:

   - point (1): the cloud point nearest the robust centroid (the mean of the DBSCAN clusters);
   - line (2): the two ends along the principal axis, placed on the fitted axis;
   - surface (3-4): per 2 x 2 voxel the point furthest towards that voxel's outer corner, projected
     on the fitted plane, in boundary order (counter-clockwise seen from the normal's side, and the
     normal is oriented to have z >= 0, as :func:`~.helpers.normal` does).

"Cloud point" means a point of the fine voxel-downsampled cloud (the mean of the raw points in one
4 mm voxel), i.e. a point on the observed surface. Every representative is also a *supported* point
(at least half the typical number of neighbours within 2.5 fine voxels, a DBSCAN core-point test),
so a stray outlier is never chosen however well it ranks. For a whole solid object the centroid of
its visible surface lies inside it, so its point element lands on the visible face nearest that
centroid (which face can change with the viewpoint); a flat part such as a top face is stable.

End-effector elements skip all this: :func:`ee_element` builds them from forward kinematics.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from code_as_monitor.core.camera import CameraModel, validate_rigid
from code_as_monitor.core.elements import MAX_CLOUD_POINTS, Element, ElementKind, ElementSpec, ElementSupport, color_for
from code_as_monitor.core.errors import ElementError, GeometryError, NoValidDepthError
from code_as_monitor.geometry.backproject import DEFAULT_MAX_DEPTH, backproject_mask
from code_as_monitor.geometry.fusion import fuse_points, remove_outliers, voxel_downsample, voxel_keys

VOXEL_DIVISIONS: dict[ElementKind, tuple[int, int, int]] = {
    ElementKind.POINT: (1, 1, 1),
    ElementKind.LINE: (2, 1, 1),
    ElementKind.SURFACE: (2, 2, 1),
}
"""Element voxels per axis of the element's own frame (principal axes; for a surface the last axis
is the plane normal): the occupied space is divided into this many voxels, one representative each."""

MIN_FINE_VOXEL = 0.004
"""Metres: the finest voxel of the downsampling grid."""
FINE_VOXELS_ACROSS = 100
"""The fine voxel is at least the part's robust extent divided by this (bounds the cloud size)."""
DBSCAN_MAX_POINTS = 1500
"""DBSCAN runs on a grid coarse enough to hold about this many points (it dominates the cost)."""

Observation3D = tuple[np.ndarray, np.ndarray, CameraModel]
"""``(mask (H, W) bool, depth (H, W) metres, camera)``: one view of one part."""


def fine_voxel_size(points: np.ndarray) -> float:
    """Fine downsampling voxel (metres) for a cloud (N, 3): max(4 mm, robust extent / 100)."""
    if len(points) < 2:
        return MIN_FINE_VOXEL
    lo, hi = np.percentile(points, [2.0, 98.0], axis=0)
    return float(max(MIN_FINE_VOXEL, (hi - lo).max() / FINE_VOXELS_ACROSS))


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


def _dense_clusters(Q: np.ndarray, voxel: float, min_cluster_frac: float = 0.1) -> np.ndarray:
    """Rows of ``Q`` (M, 3) kept by DBSCAN: every cluster at least ``min_cluster_frac`` of the largest.

    DBSCAN runs on at most about :data:`DBSCAN_MAX_POINTS` voxel centres: ``Q`` is re-gridded with a
    voxel ``g >= voxel`` chosen for that, and each row of ``Q`` takes its voxel's label. ``eps`` is
    2.5 voxels ``g`` (a surface voxel has ~20 neighbours within it), ``min_samples`` 4. Returns all
    of ``Q`` when DBSCAN finds no cluster (a tiny cloud).
    """
    if len(Q) < 8:
        return Q
    from sklearn.cluster import DBSCAN

    g = voxel * max(1.0, float(np.sqrt(len(Q) / DBSCAN_MAX_POINTS)))  # surfaces: count ~ 1 / g^2
    if g > voxel:
        _, inv = np.unique(voxel_keys(Q, g), return_inverse=True)
        inv = inv.reshape(-1)
        counts = np.bincount(inv)
        C = np.stack([np.bincount(inv, weights=Q[:, i]) for i in range(3)], axis=1) / counts[:, None]
    else:
        inv, C = np.arange(len(Q)), Q
    labels = DBSCAN(eps=2.5 * g, min_samples=4).fit_predict(C)[inv]
    good = labels >= 0
    if not good.any():
        return Q
    sizes = np.bincount(labels[good])
    keep = np.flatnonzero(sizes >= min_cluster_frac * sizes.max())
    return Q[np.isin(labels, keep)]


def _orient(d: np.ndarray) -> np.ndarray:
    """Flip the direction ``d`` (3,) so that its largest-magnitude component is positive."""
    return -d if d[int(np.argmax(np.abs(d)))] < 0 else d


class _Support:
    """Picks representatives that are DBSCAN-style core points of the fine cloud ``Q`` (M, 3).

    A point is supported when it has at least half the cloud's median number of neighbours within
    2.5 fine voxels: a lone outlier that survived the filters (say, one just behind the visible
    surface, close to the centroid) is never chosen, however well it ranks.
    """

    def __init__(self, Q: np.ndarray, voxel: float) -> None:
        from scipy.spatial import cKDTree

        self.Q = Q
        self.tree = cKDTree(Q)
        self.r = 2.5 * voxel
        sample = Q[np.linspace(0, len(Q) - 1, min(len(Q), 256)).astype(np.int64)]
        self.need = 0.5 * float(np.median(self.tree.query_ball_point(sample, self.r, return_length=True)))

    def first(self, order: np.ndarray, chunk: int = 32) -> int:
        """The first index of ``order`` (indices into Q, best first) that is supported (else ``order[0]``)."""
        for k in range(0, len(order), chunk):
            idx = order[k : k + chunk]
            ok = self.tree.query_ball_point(self.Q[idx], self.r, return_length=True) >= self.need
            if ok.any():
                return int(idx[np.argmax(ok)])
        return int(order[0])


def _fit_point(Q: np.ndarray, sup: _Support) -> np.ndarray:
    c = Q.mean(axis=0)
    return Q[sup.first(np.argsort(((Q - c) ** 2).sum(axis=1)))][None]


def _fit_line(Q: np.ndarray, sup: _Support) -> np.ndarray:
    c, axes = _principal_axes(Q)
    d = _orient(axes[0])
    s = (Q - c) @ d
    order = np.argsort(s)
    lo, hi = float(s[sup.first(order)]), float(s[sup.first(order[::-1])])
    if hi - lo < 1e-6:
        raise ElementError(f"cannot fit a line: the {len(Q)} points coincide")
    # Two element voxels along the axis: [lo, mid) and [mid, hi]; each one's representative is its
    # outer end, placed on the fitted axis so that the direction is the least-squares one.
    return np.stack([c + lo * d, c + hi * d])


def _min_area_rect(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimum-area bounding rectangle of 2-D points (M, 2): centre (2,), axes (2, 2) rows, half sizes (2,)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        H = xy[ConvexHull(xy).vertices]
    except (QhullError, ValueError):
        H = xy
    edges = np.roll(H, -1, axis=0) - H
    norms = np.linalg.norm(edges, axis=1)
    edges = edges[norms > 1e-12] / norms[norms > 1e-12, None]
    if len(edges) == 0:
        edges = np.array([[1.0, 0.0]])
    best = None
    for e in edges:
        R = np.array([e, [-e[1], e[0]]])
        r = H @ R.T
        lo, hi = r.min(axis=0), r.max(axis=0)
        area = float(np.prod(hi - lo))
        if best is None or area < best[0]:
            best = (area, R, lo, hi)
    _, R, lo, hi = best
    return ((lo + hi) / 2.0) @ R, R, (hi - lo) / 2.0


def _fit_surface(Q: np.ndarray, sup: _Support) -> np.ndarray:
    if len(Q) < 3:
        raise ElementError(f"cannot fit a surface through {len(Q)} point(s)")
    ids = np.arange(len(Q))
    c, axes = _principal_axes(Q)
    # Robust plane: refit on points within 3 robust sigmas (MAD) of the first least-squares plane.
    r = (Q - c) @ axes[2]
    dev = np.abs(r - np.median(r))
    inl = dev <= max(3.0 * 1.4826 * float(np.median(dev)), 1e-4)
    if inl.sum() >= 3:
        ids = ids[inl]
        c, axes = _principal_axes(Q[ids])
    n = axes[2] if axes[2][2] >= 0 else -axes[2]
    e1 = axes[0]
    e2 = np.cross(n, e1)  # (e1, e2, n) right-handed: counter-clockwise seen from +n
    E = np.stack([e1, e2], axis=1)  # (3, 2) plane coordinates
    xy = (Q[ids] - c) @ E
    centre, R, half = _min_area_rect(xy)
    if half.min() < 1e-6:
        raise ElementError(f"cannot fit a surface: the {len(ids)} points are collinear")
    uv = (xy - centre) @ R.T / half  # in [-1, 1]^2 over the occupied rectangle
    reps = []
    # 2 x 2 element voxels; each one's representative is its supported point furthest towards the
    # voxel's outer corner, projected on the plane.
    for su, sv in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
        cell = np.flatnonzero((su * uv[:, 0] >= 0) & (sv * uv[:, 1] >= 0))
        if len(cell) == 0:
            continue
        order = cell[np.argsort(-(su * uv[cell, 0] + sv * uv[cell, 1]))]
        reps.append((Q[sup.first(ids[order])] - c) @ E)
    if len(reps) < 3:
        raise ElementError(f"cannot fit a surface: only {len(reps)} of the 2 x 2 voxels are occupied")
    rep = np.array(reps)
    # R may be a reflection of (e1, e2): restore counter-clockwise order seen from +n.
    ang = np.arctan2(rep[:, 1] - rep[:, 1].mean(), rep[:, 0] - rep[:, 0].mean())
    rep = rep[np.argsort(ang)]
    return c + rep @ E.T


def fit_element_points(
    points: np.ndarray, kind: ElementKind | str, voxel_size: float | None = None
) -> np.ndarray:
    """The element's points from a part's cloud.

    Args:
        points: (N, 3) world frame, metres (fused, ideally outlier-filtered); non-finite rows ignored.
        kind: point | line | surface (str or :class:`ElementKind`).
        voxel_size: fine downsampling voxel in metres (default :func:`fine_voxel_size`).
    Returns:
        (k, 3) world, metres: k = 1 (point), 2 (line: ends along the principal axis), 3 or 4
        (surface: non-collinear points spanning the fitted plane, in boundary order).
    Raises:
        ElementError: unknown kind, no points, or degenerate geometry for the kind.
    """
    kind = ElementKind.parse(kind)
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ElementError(f"points must be (N, 3), got shape {P.shape}")
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) == 0:
        raise ElementError(f"cannot fit a {kind.value}: no finite points")
    vs = fine_voxel_size(P) if voxel_size is None else float(voxel_size)
    Q, _ = voxel_downsample(P, vs)
    Q = _dense_clusters(Q, vs)
    sup = _Support(Q, vs)
    if kind is ElementKind.POINT:
        return _fit_point(Q, sup)
    if kind is ElementKind.LINE:
        return _fit_line(Q, sup)
    return _fit_surface(Q, sup)


def part_cloud(
    observations: Sequence[Observation3D],
    max_depth: float = DEFAULT_MAX_DEPTH,
    k: int = 16,
    std_ratio: float = 2.0,
    name: str = "part",
) -> tuple[np.ndarray, float]:
    """Fused, downsampled, outlier-filtered cloud (M, 3) of one part over its views, and the voxel used.

    Raises:
        ShapeMismatchError: a mask, depth and camera disagree in size.
        NoValidDepthError: no view has a mask pixel with a valid depth.
    """
    Q, vs, _ = _part_cloud_views(observations, max_depth, k, std_ratio, name)
    return Q, vs


def _part_cloud_views(
    observations: Sequence[Observation3D], max_depth: float, k: int, std_ratio: float, name: str
) -> tuple[np.ndarray, float, int]:
    """:func:`part_cloud` plus the number of views that gave at least one valid point."""
    clouds = [backproject_mask(m, d, cam, max_depth, allow_empty=True) for m, d, cam in observations]
    P = fuse_points(clouds)
    if len(P) == 0:
        names = ", ".join(repr(cam.name) for _, _, cam in observations) or "(none)"
        raise NoValidDepthError(f"{name}: no mask pixel with a valid depth in any view ({names})")
    vs = fine_voxel_size(P)
    Q, _ = voxel_downsample(P, vs)
    return remove_outliers(Q, k=k, std_ratio=std_ratio), vs, sum(len(c) > 0 for c in clouds)


def cap_cloud(points: np.ndarray, max_points: int = MAX_CLOUD_POINTS, voxel: float = MIN_FINE_VOXEL) -> np.ndarray:
    """Voxel-downsample a cloud (N, 3) world metres until it holds at most ``max_points`` points.

    Starts at ``voxel`` metres and grows the voxel by the square root of the excess (clouds of surfaces
    shrink with the square of the voxel); returns the input unchanged when it is already small enough.
    """
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if max_points < 1:
        raise GeometryError(f"cap_cloud: max_points must be >= 1, got {max_points!r}")
    g = float(voxel)
    while len(P) > max_points:
        g *= max(1.1, float(np.sqrt(len(P) / max_points)))
        P, _ = voxel_downsample(P, g)
    return P


def mask_cloud(
    observations: Sequence[Observation3D], max_points: int = MAX_CLOUD_POINTS, max_depth: float = DEFAULT_MAX_DEPTH
) -> np.ndarray:
    """The fused, downsampled, outlier-filtered cloud (M, 3) world metres of masks over views, at most
    ``max_points`` points; (0, 3) when no mask pixel has a valid depth.

    Raises:
        ShapeMismatchError: a mask, depth and camera disagree in size.
    """
    try:
        Q, vs, _ = _part_cloud_views(observations, max_depth, 16, 2.0, "cloud")
    except NoValidDepthError:
        return np.empty((0, 3))
    return cap_cloud(Q, max_points, vs)


def _support(Q: np.ndarray, pts: np.ndarray, kind: ElementKind, views: int) -> ElementSupport:
    """The support record of element points ``pts`` (k, 3) fitted on cloud ``Q`` (M, 3)."""
    c, axes = _principal_axes(Q)
    s = (Q - c) @ axes.T
    extent = s.max(axis=0) - s.min(axis=0) if len(Q) else np.zeros(3)
    if kind is ElementKind.SURFACE and len(pts) >= 3:
        n = np.cross(pts[1] - pts[0], pts[2] - pts[0])
        n = n / max(float(np.linalg.norm(n)), 1e-12)
        r = (Q - pts.mean(axis=0)) @ n
    elif kind is ElementKind.LINE:
        d = (pts[1] - pts[0]) / np.linalg.norm(pts[1] - pts[0])
        X = Q - pts[0]
        r = np.linalg.norm(X - np.outer(X @ d, d), axis=1)
    else:
        r = np.linalg.norm(Q - pts[0], axis=1)
    return ElementSupport(len(Q), int(views), float(np.sqrt(np.mean(r**2))) if len(r) else 0.0,
                          float(extent.max() / 2.0) if len(Q) else 0.0,
                          (float(extent[0]), float(extent[1]), float(extent[2])))


def build_element(
    id: int,
    spec: ElementSpec,
    observations: Sequence[Observation3D],
    max_depth: float = DEFAULT_MAX_DEPTH,
    k: int = 16,
    std_ratio: float = 2.0,
) -> Element:
    """Build the element ``spec`` from its masks in one or more views.

    Args:
        id: element id (the number drawn on the images); also picks the colour.
        spec: what to abstract (object, part, kind).
        observations: ``(mask (H, W) bool, depth (H, W) metres, camera)`` per view; a view where the
            part is not visible (empty mask or no valid depth) is skipped.
        max_depth: metres; depth beyond is missing.
        k, std_ratio: statistical outlier removal parameters.
    Returns:
        The element, points in the world frame, owner ``(spec.obj, spec.part)``.
    Raises:
        ShapeMismatchError, NoValidDepthError, ElementError (degenerate geometry for the kind).
    """
    P, vs, views = _part_cloud_views(observations, max_depth, k, std_ratio, f"element {spec.name!r}")
    try:
        pts = fit_element_points(P, spec.kind, voxel_size=vs)
    except ElementError as exc:
        raise ElementError(f"element {spec.name!r} ({spec.obj}/{spec.part or '*'}): {exc}") from None
    cloud = cap_cloud(P, MAX_CLOUD_POINTS, vs)
    return Element(id, spec.name, spec.kind, pts, (spec.obj, spec.part), color_for(id), cloud=cloud,
                   support=_support(P, pts, spec.kind, views))


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
