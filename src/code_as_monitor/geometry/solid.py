"""Object-centred geometry of a part from its visible skin: an oriented box, with its hidden sides carved.

A camera sees the camera-facing half of a solid, so the centroid of the visible points is biased towards
the cameras by up to half the object. Here the part is modelled as an oriented box (a block, a pen, a book,
a lid, a rim, a handle bar; for a sphere the box encloses it) and its centre, axes and extents are read from
what the masks and depth give:

1. **Axes** (:func:`box_axes`): the largest plane in the cloud (RANSAC; a visible face) gives the first axis,
   its normal. It is not always a face (a slanted plane through two opposite faces' strips of a thin bar can hold
   more points): when its box leaves the points farther than half the plane tolerance (RMS), frames on the
   largest planes found from local samples are tried too, and the best of them wins if its box lies clearly
   closer to the points (:data:`FACE_FRAME_GAIN`). The second
   axis, when the outline seen along the first shows the part's length (elongated, and at least as long as the part
   is deep along the first axis: a bar, a lever, a book on its cover), is the edge of the near-minimal bounding
   rectangle closest to the outline's principal axis; otherwise the normal of the
   largest plane perpendicular to the first (a second visible face), and without one the rotation about the first
   axis that minimises the area of the points' bounding rectangle (the outline of a single face). The third
   completes a right-handed frame.
2. **Observed extents** (:func:`fit_box`): along each axis, the span of the points (the 99th and 1st
   percentiles); an end where a face perpendicular to the axis is seen (a spike of points there) is that
   face's plane (the median of its points). Seen from two sides, or from one side that sees two faces, a
   box's visible faces span its whole extent along every axis.
3. **Hidden sides** (:func:`~.carve.carve`): a side no view sees past may extend further than the points show (the
   back of a block seen only from the front; a block under another one; a book inside a shelf). Each side is
   pushed outwards slab by slab while the slab stays hidden in every view: in each view the depth there
   reads the part itself in front of it, or another object well in front of it (a sample less than
   :data:`~.carve.SHELL` behind another object's surface would be inside that object), never one of the object's
   other parts (a part ends where its siblings begin), and the slab is not below the support plane (the
   table). A slab any view sees through (the depth reads further), or one on a seen surface, stops it. A side that grows
   unbounded to :data:`~.carve.GROW_LIMIT` times the part's largest observed extent is hidden from every view (one
   face seen alone); the part is then taken to be as deep along that axis as the smaller of its other two
   extents, the one assumption made, and the support record counts such sides.

The element points come from the box (:mod:`code_as_monitor.geometry.elements`): a point is its centre; a
line its longest axis through the centre; a surface the plane through the centre across its thinnest axis.

Steps 1 and 2 are here; step 3 is :mod:`code_as_monitor.geometry.carve`, and the support plane (the table)
it never carves below is :mod:`code_as_monitor.geometry.support`.

All clouds (N, 3) are in the world frame, metres; ``axes`` (3, 3) hold one unit axis per row.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.geometry.stats import median
from code_as_monitor.geometry.transforms import cross

FACE_SPIKE = 0.12
"""An end of an axis is a seen face when at least this fraction of the points lie on its plane."""
MIN_SECOND_FACE = 0.06
"""The second axis comes from a perpendicular plane only when that plane holds this fraction of the points."""
RANSAC_SCORE_POINTS = 400
"""RANSAC scores its plane hypotheses on at most this many points of the cloud (the refit uses them all)."""
ELONGATED = 4.0
"""An outline whose second moment of area along its principal axis is at least this many times that across it (RMS
spans in a ratio of at least 2) is elongated: its principal axis picks among near-minimal bounding rectangles."""
OUTLINE_SPAN_DEG = 10.0
"""Bounding rectangles within this many degrees of the minimum-area one are candidates on an elongated outline."""
OUTLINE_STEP_DEG = 0.1
"""The angular step (degrees) between candidate rectangles."""
FACE_PLANES = 6
"""When the largest plane's frame does not explain the cloud, :func:`box_axes` also completes a frame on each of this
many largest distinct planes found from local samples (faces)."""
FACE_FRAME_GAIN = 2.0
"""A frame on a locally found face replaces the largest plane's (or the support's) only when its box's RMS distance to
the points is less than the other's divided by this."""
LOCAL_NEIGHBOURS = 8
"""A local plane sample is a point and two of its this many nearest points."""
SAME_PLANE_DEG = 1.0
"""Refitted plane normals closer than this (degrees) are one plane found twice (:func:`plane_candidates`)."""


@dataclass
class Box:
    """An oriented box: ``axes`` (3, 3) rows (right-handed), ``lo``/``hi`` (3,) the box's ends as coordinates
    ``p @ axes.T`` (metres), ``noise`` the estimated depth noise (metres), ``grown`` (2, 3) metres each side
    (row 0: lo, row 1: hi) moved outwards by carving, ``hidden`` (2, 3) True for a side no view bounded,
    ``assumed`` (2, 3) True for a side whose growth is the compact-solid assumption (a face seen alone; see
    :func:`~.carve.carve`), ``room`` (2, 3) metres, for a hidden or assumed side, the most it could grow as far
    as the views tell (the growth limit for a hidden one), and ``behind`` (2, 3) metres, for a side carving stopped
    at a sibling part's surface, how much further it could go on right behind that surface (see
    :func:`~.carve.behind_siblings`; the side is not assumed: parts usually end where their siblings begin)."""

    axes: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    noise: float = 0.0
    grown: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    hidden: np.ndarray = field(default_factory=lambda: np.zeros((2, 3), dtype=bool))
    assumed: np.ndarray = field(default_factory=lambda: np.zeros((2, 3), dtype=bool))
    room: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    behind: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))

    @property
    def centre(self) -> np.ndarray:
        """(3,) world, metres."""
        return ((self.lo + self.hi) / 2.0) @ self.axes

    @property
    def extent(self) -> np.ndarray:
        """(3,) metres along ``axes``."""
        return self.hi - self.lo

    @property
    def uncertainty(self) -> float:
        """Metres: how far the views let the centre lie from :attr:`centre` because of the sides whose depth is
        assumed (hidden or ``assumed``) or that may go on behind a sibling part (``behind``): per axis, half the
        larger of (the assumed growth) and (the room left beyond it, and behind the siblings), the axes combined as
        a vector; 0 when a view bounds every side."""
        guess = self.hidden | self.assumed
        g = np.where(guess, self.grown, 0.0).sum(axis=0)
        r = np.where(guess, np.maximum(self.room - self.grown, 0.0), np.maximum(self.behind, 0.0)).sum(axis=0)
        return float(np.linalg.norm(np.maximum(g, r) / 2.0))

    def residual(self, points: np.ndarray) -> float:
        """RMS distance (metres) of ``points`` (N, 3) to the box's surface: how well it explains them."""
        s = np.asarray(points, dtype=np.float64) @ self.axes.T
        c, h = (self.lo + self.hi) / 2.0, (self.hi - self.lo) / 2.0
        d = np.abs(s - c) - h  # > 0 outside along that axis
        outside = np.linalg.norm(np.maximum(d, 0.0), axis=1)
        r = np.where(outside > 0, outside, -d.max(axis=1))  # inside: the distance to the nearest face
        return float(np.sqrt(np.mean(r**2))) if len(r) else 0.0


def _plane_hypotheses(P: np.ndarray, tol: float, iters: int, rng: np.random.Generator,
                      perpendicular_to: np.ndarray | None, local: bool = False
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RANSAC's plane hypotheses: unit normals (M, 3), a point on each (M, 3), inlier counts (M,) on at most
    :data:`RANSAC_SCORE_POINTS` evenly spread points (M = 0 when every sample was degenerate). ``local``: each
    sample is a random point and two of its :data:`LOCAL_NEIGHBOURS` nearest points (a face is planar where it is
    seen, so a local sample lies on one face; three points drawn anywhere can span two)."""
    n_pts = len(P)
    k = 2 if perpendicular_to is not None else 3
    if local:
        anchors = rng.integers(0, n_pts, size=iters)
        near = min(LOCAL_NEIGHBOURS, n_pts - 1)
        Q = P[anchors]
        dx, dy, dz = (Q[:, i, None] - P[None, :, i] for i in range(3))
        d2 = dx * dx + dy * dy + dz * dz  # (iters, N); per coordinate: no (iters, N, 3) temporary
        d2[np.arange(iters), anchors] = np.inf
        nbrs = np.argpartition(d2, near - 1, axis=1)[:, :near]
        pick = np.argsort(rng.random((iters, near)), axis=1)[:, :k - 1]
        idx = np.c_[anchors, np.take_along_axis(nbrs, pick, axis=1)]
    else:
        idx = rng.integers(0, n_pts, size=(iters, k))
    A, B = P[idx[:, 0]], P[idx[:, 1]]
    N = cross(B - A, P[idx[:, 2]] - A) if perpendicular_to is None else cross(B - A, perpendicular_to[None, :])
    norm = np.linalg.norm(N, axis=1)
    ok = norm > 1e-9
    N, A = N[ok] / norm[ok, None], A[ok]
    Ps = P if n_pts <= RANSAC_SCORE_POINTS else P[np.linspace(0, n_pts - 1, RANSAC_SCORE_POINTS).astype(np.int64)]
    counts = (np.abs(Ps @ N.T - np.sum(N * A, axis=1)) <= tol).sum(axis=0)
    return N, A, counts


def _refine_plane(P: np.ndarray, n: np.ndarray, a: np.ndarray, tol: float,
                  perpendicular_to: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The hypothesis (normal ``n`` through ``a``) refitted by least squares on its inliers (keeping the
    perpendicularity): (unit normal (3,), inlier mask (N,))."""
    inl = np.abs((P - a) @ n) <= tol
    X = P[inl] - P[inl].mean(axis=0)
    if perpendicular_to is not None:
        X = X - np.outer(X @ perpendicular_to, perpendicular_to)
    if len(X) >= 3:
        _, V = np.linalg.eigh(X.T @ X)
        cand = V[:, 0] if perpendicular_to is None else V[:, 1] if abs(V[:, 0] @ perpendicular_to) > 0.9 else V[:, 0]
        if perpendicular_to is not None:
            cand = cand - (cand @ perpendicular_to) * perpendicular_to
        if np.linalg.norm(cand) > 1e-9:
            n = cand / np.linalg.norm(cand)
    return n, inl


def plane_ransac(P: np.ndarray, tol: float, iters: int, rng: np.random.Generator,
                  perpendicular_to: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The plane with most points within ``tol``: (unit normal (3,), inlier mask (N,)).

    With ``perpendicular_to`` (a unit axis), only planes containing that direction are tried (2-point samples).
    """
    return plane_candidates(P, tol, iters, rng, 1, perpendicular_to)[0]


def plane_candidates(P: np.ndarray, tol: float, iters: int, rng: np.random.Generator, most: int,
                     perpendicular_to: np.ndarray | None = None, local: bool = False
                     ) -> list[tuple[np.ndarray, np.ndarray]]:
    """Up to ``most`` distinct planes of the cloud ``P`` (N, 3), most points within ``tol`` first: each
    ``(unit normal (3,), inlier mask (N,))``, refitted by least squares on its inliers. The first is
    :func:`plane_ransac`'s. Hypotheses whose refitted normals lie within :data:`SAME_PLANE_DEG` of a kept one are
    the same plane found again. ``local``: hypotheses from local samples (see :func:`_plane_hypotheses`)."""
    n_pts = len(P)
    N, A, counts = _plane_hypotheses(P, tol, iters, rng, perpendicular_to, local and n_pts > LOCAL_NEIGHBOURS + 1)
    if len(N) == 0:
        return [(np.array([0.0, 0.0, 1.0]), np.zeros(n_pts, dtype=bool))]
    kept: list[tuple[np.ndarray, np.ndarray]] = []
    same = np.cos(np.radians(SAME_PLANE_DEG))
    for i in np.argsort(-counts, kind="stable"):
        if len(kept) >= most:
            break
        n, inl = _refine_plane(P, N[i], A[i], tol, perpendicular_to)
        if all(abs(float(n @ m)) < same for m, _ in kept):
            kept.append((n, inl))
    return kept


def _hull_moments(hull: np.ndarray) -> np.ndarray:
    """(2, 2) second moments of area about its centroid, per unit area, of the convex polygon ``hull`` (K, 2) (float32
    values: ``cv2.convexHull``'s output); zeros for a degenerate polygon."""
    import cv2

    m = cv2.moments(hull.astype(np.float32))
    if abs(m["m00"]) < 1e-12:
        return np.zeros((2, 2))
    return np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / m["m00"]


def _lengthwise(hull: np.ndarray, depth: float) -> float | None:
    """The principal angle (radians) of the outline whose convex hull is ``hull`` (K, 2) when it shows a part's
    length, else ``None``.

    It does when it is elongated (the hull's second moment of area along its principal axis at least
    :data:`ELONGATED` times that across it) and at least ``depth`` long along that axis (``depth``: the part's span
    along the view direction; a bar standing tilted, seen from above, has an elongated outline shorter than the bar).
    """
    evals, evecs = np.linalg.eigh(_hull_moments(hull))
    if evals[1] < ELONGATED * max(float(evals[0]), 1e-12):
        return None
    major = evecs[:, 1]
    return float(np.arctan2(major[1], major[0])) if float(np.ptp(hull @ major)) >= depth else None


def _outline_angle(xy: np.ndarray, tol: float, depth: float) -> tuple[float, bool]:
    """Angle (radians) of an edge direction of the bounding rectangle that frames the outline ``xy`` (M, 2), and
    whether the outline shows the part's length.

    The minimum-area rectangle, except on an outline that shows a part's length (:func:`_lengthwise`, with the
    part ``depth`` metres deep along the view): there, among the rectangles whose area is within the outline's
    resolution of the minimum (each side up to ``tol`` metres longer), the one whose edge lies closest to the
    principal axis of the outline's area (the second moments of its convex hull, which a few ragged outline points
    barely turn). On the turn-tap's levers (a 70 x 14 mm bar on a round hub) seen from two views the minimum-area
    rectangle alone was a median 3.0 degrees off the bar and this choice 0.75
    (``benchmarks/element_accuracy.py --tasks turn-tap``). On a square or round outline the principal axis is
    arbitrary and the minimum-area rectangle is kept.
    """
    import cv2

    if len(xy) < 3:
        return 0.0, False
    hull32 = cv2.convexHull(xy.astype(np.float32))
    (_, _), (w, h), ang = cv2.minAreaRect(hull32)
    theta0 = float(np.deg2rad(ang))
    hull = hull32.reshape(-1, 2).astype(np.float64)
    phi = _lengthwise(hull, depth) if len(hull) >= 3 else None
    if phi is None:
        return theta0, False
    T = theta0 + np.deg2rad(np.arange(-OUTLINE_SPAN_DEG, OUTLINE_SPAN_DEG + OUTLINE_STEP_DEG / 2, OUTLINE_STEP_DEG))
    u = hull[:, :1] * np.cos(T) + hull[:, 1:] * np.sin(T)  # (K, M) hull along each candidate edge
    v = hull[:, 1:] * np.cos(T) - hull[:, :1] * np.sin(T)
    area = np.ptp(u, axis=0) * np.ptp(v, axis=0)
    off = np.abs((T - phi + np.pi / 4) % (np.pi / 2) - np.pi / 4)  # a rectangle's edges repeat every 90 degrees
    off[area > (w + tol) * (h + tol)] = np.inf
    return (float(T[int(np.argmin(off))]) if np.isfinite(off).any() else theta0), True


def _second_axis(P: np.ndarray, a1: np.ndarray, inl: np.ndarray, tol: float, rng: np.random.Generator) -> np.ndarray:
    """Axes (3, 3) rows with first axis ``a1``; the second from the outline seen along ``a1`` when that outline
    shows the part's length (:func:`_lengthwise`, :func:`_outline_angle`); else the normal of the largest plane
    perpendicular to ``a1`` among the points off the first plane (``~inl``), and without one from the minimum-area
    rectangle of the outline.

    Along a bar its length fixes its direction better than a side face does: a side face is a narrow strip, and
    the plane through it takes in what stands a few millimetres proud of it (on the turn-tap's levers, with the
    hub, a median 3.1 degrees off the bar from two views). The plane is searched for either way, so that the
    frames completed after this one draw the same random samples whichever decides here."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(a1[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = cross(a1, helper)
    e1 /= np.linalg.norm(e1)
    e2 = cross(a1, e1)
    rest = P[~inl]
    a2 = None
    if len(rest) >= max(6, MIN_SECOND_FACE * len(P)):
        n2, inl2 = plane_ransac(rest, tol, 48, rng, perpendicular_to=a1)
        if inl2.sum() >= max(5, MIN_SECOND_FACE * len(P)):
            a2 = n2
    ang, lengthwise = _outline_angle(np.c_[P @ e1, P @ e2], tol, float(np.ptp(P @ a1)))
    if a2 is None or lengthwise:
        a2 = np.cos(ang) * e1 + np.sin(ang) * e2
    a2 = a2 - (a2 @ a1) * a1
    a2 /= np.linalg.norm(a2)
    return np.stack([a1, a2, cross(a1, a2)])


def box_axes(P: np.ndarray, tol: float, rng: np.random.Generator | None = None,
             candidates: Sequence[np.ndarray] = (), noise: float = 0.0,
             first: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Axes (3, 3) rows of the box that best explains the cloud ``P`` (N, 3).

    The first axis is the normal of the largest plane (RANSAC, inlier distance ``tol`` metres) or one of
    ``candidates`` (unit directions, e.g. the support plane's normal: most parts rest on a face); each is completed
    by :func:`_second_axis`, and the frame whose box leaves the smallest RMS distance from the points to its
    surface wins (the largest plane's on a tie). The largest plane is not always a face: on a thin bar seen from
    two sides, one end showing one face and the other end the opposite face, a plane slanted through both faces'
    strips holds more points than either face, and its frame's box leaves the points farther from its surface
    than the plane tolerance. When the winner's RMS residual exceeds ``tol / 2``, frames are also completed on the
    :data:`FACE_PLANES` largest planes found from local samples (faces), and the best of them wins if its residual
    is less than the winner's divided by :data:`FACE_FRAME_GAIN` (on small clouds every frame's residual is a
    fraction of a millimetre, and under depth noise about the noise: there the residual does not rank frames by
    their direction). ``first`` is the largest plane ``(normal, inliers)`` when already found.
    """
    rng = rng or np.random.default_rng(0)
    if len(P) < 6:
        return np.eye(3)
    a1, inl = first if first is not None else plane_ransac(P, tol, 64, rng)
    frames = [] if inl.sum() < 3 else [_second_axis(P, a1, inl, tol, rng)]
    for c in candidates:
        c = np.asarray(c, dtype=np.float64) / np.linalg.norm(c)
        frames.append(_second_axis(P, c, np.zeros(len(P), dtype=bool), tol, rng))
    if not frames:
        return np.eye(3)
    scores = [_observed_box(P, A, noise).residual(P) for A in frames]
    best = int(np.argmin(scores))
    if scores[best] <= tol / 2.0:  # its box explains the points within the plane tolerance
        return frames[best]
    # it does not: frames on faces found from local samples, the best of them if it explains the points clearly
    # better (under depth noise every frame's residual is about the noise, and the largest plane's is kept)
    same = np.cos(np.radians(SAME_PLANE_DEG))
    faces = [_second_axis(P, n, i, tol, rng) for n, i in plane_candidates(P, tol, 64, rng, FACE_PLANES, local=True)
             if i.sum() >= 3 and abs(float(n @ a1)) < same]
    face_scores = [_observed_box(P, A, noise).residual(P) for A in faces]
    if faces and min(face_scores) * FACE_FRAME_GAIN < scores[best]:
        return faces[int(np.argmin(face_scores))]
    return frames[best]


def _observed_box(P: np.ndarray, axes: np.ndarray, noise: float, tol: float = 0.002) -> Box:
    """The box along ``axes`` spanning the points ``P`` (N, 3): per axis end, the 1st / 99th percentile, or the
    median of the points within ``max(tol, 2 noise)`` of it when they are a face spike (at least FACE_SPIKE)."""
    s = np.sort(P @ axes.T, axis=0)  # (N, 3)
    n = len(s)
    ftol = max(tol, 2.0 * noise)
    ends = np.empty((2, 3))
    for row, q in ((0, 0.01), (1, 0.99)):
        e = s[round(q * (n - 1))]
        for a in range(3):
            col = s[:, a]
            i0, i1 = np.searchsorted(col, [e[a] - ftol, e[a] + ftol])
            ends[row, a] = col[i0 + (i1 - i0) // 2] if (i1 - i0) >= FACE_SPIKE * n else e[a]
    return Box(axes, ends.min(axis=0), ends.max(axis=0), noise)


def _mad_noise(P: np.ndarray, n: np.ndarray, inl: np.ndarray) -> float:
    """1.4826 x the median absolute residual (metres) of the inliers ``inl`` of the plane with normal ``n``."""
    if inl.sum() < 3:
        return 0.0
    r = P[inl] @ n
    return float(1.4826 * median(np.abs(r - median(r))))


def fit_box(P: np.ndarray, voxel: float, rng: np.random.Generator | None = None, noise: float | None = None,
            up: np.ndarray | None = None) -> Box:
    """The box of the observed points ``P`` (N, 3) (steps 1 and 2 of the module docstring).

    Args:
        P: the part's cloud, world metres.
        voxel: metres, the cloud's sampling step.
        noise: metres, the depth noise (default: estimated from the cloud's largest plane).
        up: optional unit direction tried as the first axis too (the support plane's normal).
    The RANSAC plane tolerance is ``max(voxel / 2, 2 mm, 2.5 noise)``.
    """
    P = np.asarray(P, dtype=np.float64).reshape(-1, 3)
    rng = rng or np.random.default_rng(0)
    first = None
    if noise is None:  # from the cloud's largest plane, which is then also the first axis's candidate
        tol = max(voxel / 2.0, 0.002)
        first = plane_ransac(P, tol, 64, rng) if len(P) >= 6 else None
        noise = 0.0 if first is None else _mad_noise(P, *first)
    tol = max(voxel / 2.0, 0.002, 2.5 * noise)
    if first is not None and tol > max(voxel / 2.0, 0.002):
        first = None  # noisy: search again with the wider tolerance
    axes = box_axes(P, tol, rng, () if up is None else (up,), noise, first)
    return _observed_box(P, axes, noise, tol)


__all__ = ["Box", "box_axes", "fit_box", "plane_candidates", "plane_ransac"]
