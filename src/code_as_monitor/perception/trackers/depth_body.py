"""Rigid bodies for the depth tracker: model clouds, scene crops, registration with small_gicp, and the
projective support check that decides whether a registered pose is seen.

Frames: a body's *model frame* is the world frame at the time its cloud was painted; its pose ``T``
(4, 4) maps model-frame points to the world frame now (identity at paint time). Clouds are (N, 3)
metres. Depth images follow the core contract: (H, W) metres along the optical axis, 0 or NaN = no
reading.

Registration (:func:`register`): the *target* is the body's model (voxel-downsampled, normals and a
KdTree built once by small_gicp); the *source* is the current frame's scene points cropped around the
body (:func:`crop_scene`), so the per-frame cost is one crop, one voxel grid and the ICP iterations.
small_gicp estimates ``T_target_source`` (scene -> model frame); the body's pose is its inverse.

Support (:func:`support`): the model points are put at a candidate pose and projected into every view.
Where the depth reading agrees with the point's depth (within ``tol``) the point is *seen*; where the
camera sees further than the point (the reading lies behind it) the pose is *contradicted* there;
where something is in front it is *occluded* (no evidence either way), and pixels without a reading
tell nothing. A pose is accepted when enough points are seen and few are contradicted.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.errors import GeometryError, ShapeMismatchError
from code_as_monitor.core.observation import View

Plane = tuple[np.ndarray, float]
"""A plane ``n . p + d = 0``: unit normal (3,) and offset (metres)."""


@dataclass
class Support:
    """Projective evidence for one pose: model points seen, contradicted and occluded over all views."""

    seen: int = 0
    contradicted: int = 0
    occluded: int = 0
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


def check_view(view: View) -> None:
    """Raise ShapeMismatchError / GeometryError naming what is wrong with a view's depth or camera.

    ``View`` validates its arrays when built; this re-checks what a caller may have replaced since.
    """
    cam = view.camera
    K = getattr(cam, "K", None)
    if K is None or np.shape(K) != (3, 3) or not np.all(np.isfinite(K)):
        raise GeometryError(f"view {getattr(cam, 'name', '?')!r}: camera intrinsics K missing or invalid: {K!r}")
    depth = view.depth
    if np.ndim(depth) != 2 or np.shape(depth) != (cam.height, cam.width):
        raise ShapeMismatchError(
            f"view {cam.name!r}: depth shape {np.shape(depth)} does not match the camera's "
            f"(height, width) = {(cam.height, cam.width)}"
        )


class ViewData:
    """One view's depth and camera in the form the per-frame loops use (matrices computed once).

    Attributes:
        depth: (H, W) metres (0 / NaN = no reading).
        width, height: pixels.
        fx, fy, cx, cy: intrinsics, pixels.
        R_cw, t_cw: world -> camera rotation (3, 3) and translation (3,).
        R_wc, t_wc: camera -> world.
    """

    def __init__(self, view: View) -> None:
        check_view(view)
        cam = view.camera
        self.name = cam.name
        self.depth = view.depth
        self.width, self.height = int(cam.width), int(cam.height)
        K = np.asarray(cam.K, dtype=np.float64)
        self.fx, self.fy, self.cx, self.cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
        T = np.asarray(cam.T_world_cam, dtype=np.float64)
        self.R_wc, self.t_wc = T[:3, :3], T[:3, 3]
        self.R_cw = self.R_wc.T
        self.t_cw = -self.R_cw @ self.t_wc
        self._nearest: np.ndarray | None = None

    def nearest(self) -> np.ndarray:
        """(H, W) float32: the nearest valid reading in each pixel's 3x3 neighbourhood (inf: none).

        A model point counts as contradicted only when even this reading lies behind it, so a point on an
        object's outline whose pixel rounds onto the background behind is not held against its pose.
        """
        if self._nearest is None:
            import cv2

            d = np.asarray(self.depth, dtype=np.float32)
            d = np.where((d > 0) & np.isfinite(d), d, np.float32(np.inf))
            self._nearest = cv2.erode(d, np.ones((3, 3), np.uint8))
        return self._nearest

    def project(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates u (N,), v (N,) and camera depth z (N,) of world points ``P`` (N, 3)."""
        pc = P @ self.R_cw.T + self.t_cw
        z = pc[:, 2]
        zs = np.where(z > 1e-9, z, np.inf)
        return pc[:, 0] / zs * self.fx + self.cx, pc[:, 1] / zs * self.fy + self.cy, z


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


def support(points: np.ndarray, views: Sequence[ViewData], tol: float, max_depth: float) -> Support:
    """Projective evidence for world points ``points`` (N, 3) in every view (see the module docstring)."""
    out = Support()
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
        out.seen += s
        behind = valid & (diff > tol)
        if behind.any():
            behind[behind] = view.nearest()[vi[behind], ui[behind]] > zi[behind] + tol
        out.contradicted += int(np.count_nonzero(behind))
        out.occluded += int(np.count_nonzero(valid & (diff < -tol)))
        out.views += s > 0
    return out


def crop_scene(views: Sequence[ViewData], boxes: Sequence[np.ndarray], margin_px: int, box_margin: float,
               max_depth: float, plane: Plane | None, plane_band: float,
               tool: tuple[np.ndarray, np.ndarray, float, float] | None, max_pixels: int = 4000) -> np.ndarray:
    """World points (N, 3) of the current depth images around a body's predicted poses.

    Args:
        views: the current views.
        boxes: the body's model bounding-box corners (8, 3) world at each candidate pose.
        margin_px: the image region is the corners' projected bounding box grown by this many pixels.
        box_margin: metres; kept points lie in the corners' world bounding box grown by this.
        plane, plane_band: points within ``plane_band`` of the support plane are dropped.
        tool: ``(tip (3,), axis (3,) from the tip into the tool, radius, margin)``: points further than
            ``margin`` up the axis and within ``radius`` of it (the end-effector itself) are dropped.
        max_pixels: a bigger image region is read with a stride that leaves about this many pixels.
    """
    allp = np.concatenate(boxes)
    lo = allp.min(axis=0) - box_margin
    hi = allp.max(axis=0) + box_margin
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    out = []
    for view in views:
        u, v, z = view.project(corners)
        if not (z > 1e-6).any():
            continue
        if (z <= 1e-6).any():  # the box reaches behind the camera: search the whole image
            u0, u1, v0, v1 = 0, view.width, 0, view.height
        else:
            u0 = max(0, int(np.floor(u.min())) - margin_px)
            u1 = min(view.width, int(np.ceil(u.max())) + margin_px + 1)
            v0 = max(0, int(np.floor(v.min())) - margin_px)
            v1 = min(view.height, int(np.ceil(v.max())) + margin_px + 1)
        if u1 <= u0 or v1 <= v0:
            continue
        k = max(1, int(np.sqrt((u1 - u0) * (v1 - v0) / max_pixels)))
        roi = view.depth[v0:v1:k, u0:u1:k]
        good = (roi >= max(float(z.min()), 1e-6)) & (roi <= min(float(z.max()), max_depth))  # False for NaN
        vv, uu = np.nonzero(good)
        if not len(vv):
            continue
        zz = roi[vv, uu].astype(np.float64)
        pc = np.empty((len(zz), 3))
        pc[:, 0] = (uu * k + (u0 - view.cx)) * (zz / view.fx)
        pc[:, 1] = (vv * k + (v0 - view.cy)) * (zz / view.fy)
        pc[:, 2] = zz
        world = pc @ view.R_wc.T + view.t_wc
        keep = np.all((world >= lo) & (world <= hi), axis=1)
        out.append(world[keep])
    if not out:
        return np.zeros((0, 3))
    P = np.concatenate(out)
    if plane is not None and len(P):
        P = P[np.abs(P @ plane[0] + plane[1]) > plane_band]
    if tool is not None and len(P):
        tip, axis, radius, margin = tool
        rel = P - tip
        along = rel @ axis
        radial2 = (rel * rel).sum(axis=1) - along * along
        P = P[~((along > margin) & (radial2 < radius * radius))]
    return P
