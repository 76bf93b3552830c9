"""Rigid bodies for the depth tracker: model clouds, registration with small_gicp, and the
projective support check that decides whether a registered pose is seen.

Frames: a body's *model frame* is the world frame at the time its cloud was painted; its pose ``T``
(4, 4) maps model-frame points to the world frame now (identity at paint time). Clouds are (N, 3)
metres. Depth images follow the core contract: (H, W) metres along the optical axis, 0 or NaN = no
reading.

Registration (:func:`register`): the *target* is the body's model (voxel-downsampled, normals and a
KdTree built once by small_gicp); the *source* is the current frame's scene points cropped around the
body (:func:`.depth_views.crop_scene`), so the per-frame cost is one crop, one voxel grid and the ICP iterations.
small_gicp estimates ``T_target_source`` (scene -> model frame); the body's pose is its inverse.

Support (:func:`support`): the model points are put at a candidate pose and projected into every view.
Where the depth reading agrees with the point's depth (within ``tol``) the point is *seen*; where the
camera sees further than the point (the reading lies behind it) the pose is *contradicted* there;
where something is in front it is *occluded* (no evidence either way), and pixels without a reading
tell nothing. A pose is accepted when enough points are seen and few are contradicted.

Colour (:func:`model_chroma`, the ``chroma`` argument of :func:`support`): a model point remembers the chromaticity
(R, G) / (R + G + B) of the pixels that saw it when the body was painted; a seen point whose pixel now has another
colour (further than ``max_chroma``) is also counted *recoloured*: another object's surface may lie where the pose
puts the body's (a block in a tower, registered half onto the block that has just landed on it, sees its front face
continued by the upper block's: the same depth, another colour). Recoloured points still count as seen, since a
surface turned to the light changes its colour too (the renderer's highlight on a book's spine turned upright);
the search ranks poses by the points seen in their own colour (:func:`~.depth_search.score`). A point on a colour
edge, or that the views saw in different colours, a pixel darker than ``min_sum`` (R + G + B, 0-765), and a point no
view saw at paint time have no colour.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.errors import GeometryError
from code_as_monitor.perception.trackers.depth_views import Plane, ViewData


@dataclass
class Support:
    """Projective evidence for one pose: model points seen, contradicted and occluded over all views."""

    seen: int = 0
    contradicted: int = 0
    occluded: int = 0
    recoloured: int = 0  # of the seen points, those in another colour than when painted (model_chroma)
    views: int = 0  # views with at least one seen point
    residual: float = 0.0  # metres, mean |depth reading - point depth| over the seen points

    @property
    def contradiction(self) -> float:
        """Fraction of the informative points (seen + contradicted) that contradict the pose."""
        n = self.seen + self.contradicted
        return self.contradicted / n if n else 1.0


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse of a rigid (4, 4) transform."""
    R, t = T[:3, :3], T[:3, 3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ t
    return out


def apply(T: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(N, 3) points ``P`` mapped by the rigid transform ``T`` (4, 4)."""
    return P @ T[:3, :3].T + T[:3, 3]


class RigidBody:
    """A body's model cloud prepared for small_gicp (the registration target).

    Args:
        cloud: (M, 3) world metres at paint time (the model frame).
        voxel: downsampling voxel, metres (grown until at most ``max_points`` remain; the scene is
            downsampled with the same voxel, :attr:`voxel`).
        plane: the support plane, or None; model points within ``plane_band`` of it are left out (the
            scene's points there are removed too), unless that would leave too few.
        plane_band: metres.
        min_points: fewest model points a body needs.
    Raises:
        GeometryError: the cloud has fewer than ``min_points`` finite points.
    """

    def __init__(self, cloud: np.ndarray, voxel: float, plane: Plane | None, plane_band: float,
                 min_points: int = 6, max_points: int = 600) -> None:
        import small_gicp

        P = np.asarray(cloud, dtype=np.float64).reshape(-1, 3)
        P = P[np.isfinite(P).all(axis=1)]
        if len(P) < min_points:
            raise GeometryError(f"a body cloud needs at least {min_points} finite points, got {len(P)}")
        self.in_plane = False
        if plane is not None:
            off = np.abs(P @ plane[0] + plane[1]) > plane_band
            if off.sum() >= max(min_points, 0.2 * len(P)):
                P = P[off]
            else:
                self.in_plane = True  # a flat object lying in the plane (a marked zone): keep it whole
        pc = small_gicp.voxelgrid_sampling(P, voxel)
        while pc.size() > max_points:  # a big object: a coarser grid bounds the per-frame cost
            voxel *= max(1.2, float(np.sqrt(pc.size() / max_points)))
            pc = small_gicp.voxelgrid_sampling(P, voxel)
        if pc.size() < min_points:
            pc = small_gicp.PointCloud(P)
        self.voxel = voxel
        self.tree = small_gicp.KdTree(pc)
        small_gicp.estimate_normals_covariances(pc, self.tree, 10)
        self.cloud = pc
        self.points = np.ascontiguousarray(pc.points()[:, :3])
        lo, hi = self.points.min(axis=0), self.points.max(axis=0)
        self.radius = float(np.linalg.norm(hi - lo) / 2)
        self.centre = (lo + hi) / 2
        self.box = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        self.chroma: np.ndarray | None = None  # (M, 2) the points' chromaticity when painted (model_chroma)


def register(body: RigidBody, source: object, T_init: np.ndarray, kind: str, max_corr: Sequence[float],
             max_iterations: int, min_information: float = 0.0) -> tuple[np.ndarray, int]:
    """Register the scene cloud ``source`` (small_gicp PointCloud, world) to ``body``'s model.

    Args:
        T_init: (4, 4) initial body pose (model frame -> world).
        kind: small_gicp registration type ("PLANE_ICP", "GICP" or "ICP").
        max_corr: correspondence distances (metres) of successive rounds, coarse to fine.
        min_information: a world direction in which the final registration's translation information
            (the translation block of small_gicp's Hessian, in the source = world frame: about the
            number of inliers whose normals point that way) is below this fraction of the strongest
            direction's is *degenerate*: the scene cannot tell where the body is along it (a block
            whose only visible faces are vertical slides freely up and down), so the translation keeps
            the initial pose's value there.
    Returns:
        The registered pose (4, 4) and the number of inlier correspondences of the last round.
    """
    import small_gicp

    T_ts = invert(T_init)
    inliers = 0
    H = None
    for dist in max_corr:
        res = small_gicp.align(body.cloud, source, body.tree, T_ts, registration_type=kind,
                               max_correspondence_distance=float(dist), max_iterations=max_iterations)
        T_ts = np.asarray(res.T_target_source, dtype=np.float64)
        inliers = int(res.num_inliers)
        H = res.H
    T = invert(T_ts)
    if min_information > 0 and H is not None:
        w, E = np.linalg.eigh(np.asarray(H, dtype=np.float64)[3:, 3:])
        weak = w < min_information * max(float(w[-1]), 1e-12)
        if weak.any():
            d = T[:3, 3] - T_init[:3, 3]
            for e in E[:, weak].T:
                d = d - (d @ e) * e
            T[:3, 3] = T_init[:3, 3] + d
    return T, inliers


def pixel_chroma(view: ViewData, vi: np.ndarray, ui: np.ndarray, min_sum: float) -> np.ndarray:
    """(N, 2) chromaticity (R, G) / (R + G + B) of ``view``'s pixels (row ``vi``, column ``ui``); NaN where the view
    has no colour image or the pixel is darker than ``min_sum`` (R + G + B, 0-765)."""
    out = np.full((len(vi), 2), np.nan)
    if view.rgb is None or not len(vi):
        return out
    px = view.rgb[vi, ui].astype(np.float64)
    total = px.sum(axis=1)
    ok = total >= max(min_sum, 1e-6)
    out[ok] = px[ok, :2] / total[ok, None]
    return out


def model_chroma(points: np.ndarray, views: Sequence[ViewData], tol: float, max_depth: float,
                 min_sum: float, max_chroma: float) -> np.ndarray:
    """(N, 2) the chromaticity of world points ``points`` (N, 3) as the views see them now (the mean over the views
    whose depth reading at the point's pixel agrees with it, within ``tol``); NaN where no view sees it in colour,
    where the pixel lies on a colour edge (a pixel of its 3 x 3 neighbourhood further than ``max_chroma`` from it:
    the next frame may round the point onto the other side), and where two views disagree by more than that."""
    lo = np.full((len(points), 2), np.inf)
    hi = np.full((len(points), 2), -np.inf)
    acc = np.zeros((len(points), 2))
    n = np.zeros(len(points))
    for view in views:
        u, v, z = view.project(points)
        u, v = np.rint(u), np.rint(v)
        inside = (z > 0) & (u >= 1) & (u <= view.width - 2) & (v >= 1) & (v <= view.height - 2)
        idx = np.flatnonzero(inside)
        if not len(idx):
            continue
        vi, ui = v[idx].astype(np.intp), u[idx].astype(np.intp)
        d = view.depth[vi, ui]
        seen = (d > 0) & (d <= max_depth) & (np.abs(d - z[idx]) <= tol)
        vi, ui, rows = vi[seen], ui[seen], idx[seen]
        ch = pixel_chroma(view, vi, ui, min_sum)
        ok = np.isfinite(ch).all(axis=1)
        for dv in (-1, 0, 1):
            for du in (-1, 0, 1):
                if dv or du:
                    nb = pixel_chroma(view, vi + dv, ui + du, min_sum)
                    ok &= ~(np.linalg.norm(nb - ch, axis=1) > max_chroma)  # a dark neighbour tells nothing
        rows, ch = rows[ok], ch[ok]
        acc[rows] += ch
        n[rows] += 1
        lo[rows] = np.minimum(lo[rows], ch)
        hi[rows] = np.maximum(hi[rows], ch)
    out = np.full((len(points), 2), np.nan)
    known = (n > 0) & ~(np.linalg.norm(hi - lo, axis=1) > max_chroma)
    out[known] = acc[known] / n[known, None]
    return out


def support(points: np.ndarray, views: Sequence[ViewData], tol: float, max_depth: float,
            chroma: np.ndarray | None = None, max_chroma: float = 0.0, min_sum: float = 60.0) -> Support:
    """Projective evidence for world points ``points`` (N, 3) in every view (see the module docstring).

    ``chroma`` (N, 2): the points' chromaticity when painted (:func:`model_chroma`; NaN unknown); with
    ``max_chroma`` > 0, a seen point whose pixel's colour is further than that from its own is also counted
    recoloured. Pixels darker than ``min_sum`` have no colour."""
    out = Support()
    test_colour = chroma is not None and max_chroma > 0 and len(chroma) == len(points)
    for view in views:
        u, v, z = view.project(points)
        u = np.rint(u)
        v = np.rint(v)
        inside = (z > 0) & (u >= 0) & (u <= view.width - 1) & (v >= 0) & (v <= view.height - 1)
        if not inside.any():
            continue
        vi, ui = v[inside].astype(np.intp), u[inside].astype(np.intp)
        d = view.depth[vi, ui]
        zi = z[inside]
        valid = (d > 0) & (d <= max_depth)  # False for NaN
        diff = d - zi
        seen = valid & (np.abs(diff) <= tol)
        s = int(np.count_nonzero(seen))
        if s:
            out.residual = (out.residual * out.seen + float(np.abs(diff[seen]).sum())) / (out.seen + s)
            if test_colour:
                rows = np.flatnonzero(seen)
                own = chroma[np.flatnonzero(inside)[rows]]
                now = pixel_chroma(view, vi[rows], ui[rows], min_sum)
                out.recoloured += int(np.count_nonzero(np.linalg.norm(now - own, axis=1) > max_chroma))  # NaN: no
        out.seen += s
        behind = valid & (diff > tol)
        if behind.any():
            behind[behind] = view.nearest()[vi[behind], ui[behind]] > zi[behind] + tol
        out.contradicted += int(np.count_nonzero(behind))
        out.occluded += int(np.count_nonzero(valid & (diff < -tol)))
        out.views += s > 0
    return out
