"""Per-frame view data for the depth tracker: cameras as matrices, the scene cropped around a body's
predicted poses, and the support plane.

Depth images follow the core contract: (H, W) metres along the optical axis, 0 or NaN = no reading.
World frame z up, metres; OpenCV camera axes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from code_as_monitor.core.errors import GeometryError, ShapeMismatchError
from code_as_monitor.core.observation import View

Plane = tuple[np.ndarray, float]
"""A plane ``n . p + d = 0``: unit normal (3,) and offset (metres)."""


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
        rgb: (H, W, 3) uint8 colour, or None when the view has none of the depth's size.
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
        self.rgb = view.rgb if getattr(view, "rgb", None) is not None and np.ndim(view.rgb) == 3 \
            and np.shape(view.rgb)[:2] == np.shape(view.depth) else None
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


def lift_all(view: ViewData, max_depth: float, stride: int) -> np.ndarray:
    """World points (N, 3) of every ``stride``-th pixel (both axes) of a view with a valid reading."""
    roi = view.depth[::stride, ::stride]
    vv, uu = np.nonzero((roi > 0) & (roi <= max_depth))
    z = roi[vv, uu].astype(np.float64)
    pc = np.stack([(uu * stride - view.cx) * z / view.fx, (vv * stride - view.cy) * z / view.fy, z], axis=1)
    return pc @ view.R_wc.T + view.t_wc


def fit_support_plane(views: Sequence[ViewData], band: float, max_depth: float) -> Plane | None:
    """The dominant plane of the views' depth (RANSAC, inliers within ``band / 2`` metres), when at least a quarter
    of the pixels lie within ``band`` of it; its normal points to the first camera's side."""
    from code_as_monitor.perception.segmenters.color import fit_plane_ransac

    if band <= 0 or not views:
        return None
    P = np.concatenate([lift_all(v, max_depth, 7) for v in views])
    if len(P) < 50:
        return None
    fit = fit_plane_ransac(P, 0.5 * band, 64, np.random.default_rng(0))
    if fit is None:
        return None
    n, d = fit
    if (np.abs(P @ n + d) <= band).mean() < 0.25:
        return None
    return (n, d) if n @ views[0].t_wc + d > 0 else (-n, -d)
