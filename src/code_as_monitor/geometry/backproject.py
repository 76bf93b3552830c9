"""Lift pixels with metric depth to 3-D points in the world frame.

Camera frame: OpenCV (x right, y down, z forward). A pixel ``(u, v)`` (u = column, v = row) with depth
``z`` (metres along the optical axis, *not* along the ray) is the camera-frame point
``z * K^-1 [u, v, 1]``, and ``camera.T_world_cam`` takes it to the world frame (z up, metres).

A depth reading is valid when it is finite, > 0 and <= ``max_depth``; anything else (0, NaN, inf,
negative, beyond range) is skipped.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import GeometryError, NoValidDepthError, ShapeMismatchError

DEFAULT_MAX_DEPTH = 5.0
"""Metres; depth readings beyond this are treated as missing."""


def check_depth(depth: np.ndarray, camera: CameraModel) -> np.ndarray:
    """Return ``depth`` as an (H, W) float array; raise ShapeMismatchError unless it matches ``camera``."""
    depth = np.asarray(depth)
    if depth.ndim != 2:
        raise ShapeMismatchError(f"camera {camera.name!r}: depth must be (H, W), got shape {depth.shape}")
    if depth.shape != (camera.height, camera.width):
        raise ShapeMismatchError(
            f"camera {camera.name!r}: depth shape {depth.shape} does not match the camera's "
            f"(height, width) = {(camera.height, camera.width)}"
        )
    if not np.issubdtype(depth.dtype, np.floating):
        depth = depth.astype(np.float32)
    return depth


def valid_depth(depth: np.ndarray, max_depth: float = DEFAULT_MAX_DEPTH) -> np.ndarray:
    """(H, W) or (N,) bool: finite, strictly positive and at most ``max_depth`` metres."""
    with np.errstate(invalid="ignore"):
        return np.isfinite(depth) & (depth > 0) & (depth <= max_depth)


def _lift(u: np.ndarray, v: np.ndarray, z: np.ndarray, camera: CameraModel) -> np.ndarray:
    """World points (N, 3) for pixel coordinates ``u, v`` (N,) and depths ``z`` (N,), all float."""
    Kinv = np.linalg.inv(camera.K)
    x = Kinv[0, 0] * u + Kinv[0, 1] * v + Kinv[0, 2]
    y = Kinv[1, 0] * u + Kinv[1, 1] * v + Kinv[1, 2]
    w = Kinv[2, 0] * u + Kinv[2, 1] * v + Kinv[2, 2]  # 1 for any K with last row [0, 0, 1]
    s = z / w
    R = camera.T_world_cam[:3, :3]
    t = camera.T_world_cam[:3, 3]
    # p_world = R @ (s * [x, y, w]) + t, written column by column to stay in (N,) arrays.
    xs, ys, zs = s * x, s * y, s * w
    out = np.empty((len(z), 3), dtype=np.float64)
    for i in range(3):
        out[:, i] = R[i, 0] * xs + R[i, 1] * ys + R[i, 2] * zs + t[i]
    return out


def backproject_mask(
    mask: np.ndarray,
    depth: np.ndarray,
    camera: CameraModel,
    max_depth: float = DEFAULT_MAX_DEPTH,
    allow_empty: bool = False,
) -> np.ndarray:
    """World points (N, 3) of the mask's pixels that have a valid depth reading.

    Args:
        mask: (H, W) bool (or 0/1) mask of the entity/part in this view.
        depth: (H, W) metric depth, metres along the optical axis; 0 / NaN / > max_depth = missing.
        camera: the view's calibrated camera (its size must be (W, H)).
        max_depth: metres; readings beyond are skipped.
        allow_empty: return an empty (0, 3) array instead of raising when nothing is valid.
    Returns:
        (N, 3) float64 world frame, metres, one point per valid mask pixel (row-major pixel order).
    Raises:
        ShapeMismatchError: mask and depth (or camera size) disagree.
        NoValidDepthError: no mask pixel has a valid depth (unless ``allow_empty``).
    """
    depth = check_depth(depth, camera)
    mask = np.asarray(mask)
    if mask.shape != depth.shape:
        raise ShapeMismatchError(
            f"camera {camera.name!r}: mask shape {mask.shape} does not match depth shape {depth.shape}"
        )
    if max_depth <= 0:
        raise GeometryError(f"max_depth must be > 0, got {max_depth!r}")
    rows, cols = mask_pixels(mask.astype(bool, copy=False))
    z = depth[rows, cols].astype(np.float64)
    ok = valid_depth(z, max_depth)
    if not ok.any():
        if allow_empty:
            return np.empty((0, 3), dtype=np.float64)
        raise NoValidDepthError(
            f"camera {camera.name!r}: the mask ({len(z)} pixels) has no valid depth reading "
            f"(0 < depth <= {max_depth} m)"
        )
    return _lift(cols[ok].astype(np.float64), rows[ok].astype(np.float64), z[ok], camera)


def mask_pixels(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.nonzero(mask)`` of an (H, W) mask, (rows, cols) int64 in row-major order, found inside the window its
    set pixels span: two ``any`` reductions locate it, so a small object's mask costs a fraction of scanning every
    pixel for indices (``np.nonzero`` over a whole 640 x 480 image costs about 15 such reductions)."""
    m = np.asarray(mask)
    if m.ndim != 2:
        raise ShapeMismatchError(f"mask must be (H, W), got shape {m.shape}")
    rows = np.flatnonzero(m.any(axis=1))
    if not len(rows):
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    r0, r1 = int(rows[0]), int(rows[-1]) + 1
    band = m[r0:r1]
    cols = np.flatnonzero(band.any(axis=0))
    c0, c1 = int(cols[0]), int(cols[-1]) + 1
    rr, cc = np.nonzero(band[:, c0:c1])
    return rr.astype(np.int64, copy=False) + r0, cc.astype(np.int64, copy=False) + c0


def lift_depth(
    depth: np.ndarray, camera: CameraModel, max_depth: float = DEFAULT_MAX_DEPTH
) -> tuple[np.ndarray, np.ndarray]:
    """Every pixel lifted at once: ``(points (H, W, 3) world metres, valid (H, W) bool)``; invalid pixels hold 0.

    The painter lifts each view once and takes every element's points from it (``points[mask & valid]``).

    Raises:
        ShapeMismatchError: depth does not match the camera.
    """
    depth = check_depth(depth, camera)
    if max_depth <= 0:
        raise GeometryError(f"max_depth must be > 0, got {max_depth!r}")
    valid = valid_depth(depth, max_depth)
    rays, origin = _world_rays(camera)
    z = np.where(valid, depth, 0.0).astype(np.float64)
    out = z[..., None] * rays
    out += origin
    out[~valid] = 0.0
    return out, valid


class LiftedView:
    """A view's depth made ready to lift pixel sets: ``valid`` (H, W) bool and :meth:`points`.

    The painter takes every element's points from it. Only the pixels asked for are lifted, so a subgoal with
    a few small parts does not pay for lifting the whole image; the points equal :func:`lift_depth`'s at the
    same pixels (the same ray times depth plus origin, row-major order).
    """

    def __init__(self, depth: np.ndarray, camera: CameraModel, max_depth: float = DEFAULT_MAX_DEPTH) -> None:
        depth = check_depth(depth, camera)
        if max_depth <= 0:
            raise GeometryError(f"max_depth must be > 0, got {max_depth!r}")
        self.depth = depth
        self.valid = valid_depth(depth, max_depth)
        self.rays, self.origin = _world_rays(camera)

    def points(self, mask: np.ndarray, corner: tuple[int, int] = (0, 0)) -> np.ndarray:
        """World points (N, 3) float64, metres, of the ``mask`` bool pixels with a valid depth reading.

        ``mask`` is (H, W), or a window (h, w) of the image whose first pixel is ``corner`` = (row, column):
        the same points as the whole-image mask with that window set, in the same (row-major) order. Either way
        only the window the mask's pixels span is scanned for them (:func:`mask_pixels`)."""
        r0, c0 = corner
        rows, cols = mask_pixels(mask)
        if r0 or c0:
            rows, cols = rows + r0, cols + c0
        keep = self.valid[rows, cols]
        rows, cols = rows[keep], cols[keep]
        out = self.depth[rows, cols].astype(np.float64)[:, None] * self.rays[rows, cols]
        out += self.origin
        return out


_RAYS: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _world_rays(camera: CameraModel) -> tuple[np.ndarray, np.ndarray]:
    """``(rays (H, W, 3), origin (3,))`` such that the pixel (u, v) at depth z lifts to ``z * rays[v, u] +
    origin`` in the world frame: ``rays = R K^-1 [u, v, 1] / w`` (unit optical-axis component). Cached per
    camera model (a replay lifts every frame of the same cameras)."""
    key = np.array([camera.width, camera.height], dtype=np.float64).tobytes() + np.asarray(
        camera.K, dtype=np.float64).tobytes() + np.asarray(camera.T_world_cam, dtype=np.float64).tobytes()
    hit = _RAYS.get(key)
    if hit is not None:
        return hit
    v, u = np.mgrid[0:camera.height, 0:camera.width].astype(np.float64)
    Kinv = np.linalg.inv(camera.K)
    x = Kinv[0, 0] * u + Kinv[0, 1] * v + Kinv[0, 2]
    y = Kinv[1, 0] * u + Kinv[1, 1] * v + Kinv[1, 2]
    w = Kinv[2, 0] * u + Kinv[2, 1] * v + Kinv[2, 2]
    cam = np.stack([x / w, y / w, np.ones_like(w)], axis=-1)  # (H, W, 3) camera frame, z = 1
    R = np.asarray(camera.T_world_cam, dtype=np.float64)[:3, :3]
    rays = cam @ R.T
    origin = np.asarray(camera.T_world_cam, dtype=np.float64)[:3, 3].copy()
    rays.flags.writeable = origin.flags.writeable = False
    if len(_RAYS) >= 16:
        _RAYS.clear()
    _RAYS[key] = (rays, origin)
    return rays, origin


def sample_depth(uv: np.ndarray, depth: np.ndarray, max_depth: float = DEFAULT_MAX_DEPTH) -> np.ndarray:
    """Robust depth (N,) at pixels ``uv`` (N, 2): median of the valid readings in the 3x3 neighbourhood
    of the rounded pixel; NaN where the pixel is outside the image or no neighbour is valid."""
    H, W = depth.shape
    n = uv.shape[0]
    good = np.all(np.isfinite(uv), axis=1)
    c = np.zeros((n, 2), dtype=np.int64)
    c[good] = np.rint(uv[good]).astype(np.int64)
    inside = good & (c[:, 0] >= 0) & (c[:, 0] < W) & (c[:, 1] >= 0) & (c[:, 1] < H)
    offs = np.array([-1, 0, 1])
    cu = np.clip(c[:, 0:1] + offs[None, :], 0, W - 1)  # (N, 3)
    cv = np.clip(c[:, 1:2] + offs[None, :], 0, H - 1)
    D = depth[cv[:, :, None], cu[:, None, :]].reshape(n, 9).astype(np.float64)  # (N, 9)
    D[~valid_depth(D, max_depth)] = np.inf  # invalid readings sort last
    D.sort(axis=1)
    cnt = np.isfinite(D).sum(axis=1)
    lo = np.clip((cnt - 1) // 2, 0, 8)
    hi = np.clip(cnt // 2, 0, 8)
    idx = np.arange(n)
    out = 0.5 * (D[idx, lo] + D[idx, hi])
    out[(cnt == 0) | ~inside] = np.nan
    return out


def backproject_pixels(
    uv: np.ndarray,
    depth: np.ndarray,
    camera: CameraModel,
    max_depth: float = DEFAULT_MAX_DEPTH,
) -> tuple[np.ndarray, np.ndarray]:
    """Lift tracked 2-D points to the world frame (the per-frame path of the trackers; vectorised).

    The depth at each point is the median of the valid readings in the 3x3 neighbourhood of its
    rounded pixel (robust to a missing reading or a depth edge); the point itself is lifted at its
    sub-pixel ``(u, v)``.

    Args:
        uv: (N, 2) pixel coordinates (u = column, v = row), float.
        depth: (H, W) metric depth of the view, metres.
        camera: the view's camera.
        max_depth: metres; readings beyond are missing.
    Returns:
        points: (N, 3) world frame, metres; rows where ``valid`` is False are NaN.
        valid: (N,) bool: inside the image with at least one valid depth reading nearby.
    Raises:
        ShapeMismatchError: ``uv`` is not (N, 2) or depth does not match the camera.
    """
    depth = check_depth(depth, camera)
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim == 1 and uv.shape == (2,):
        uv = uv[None]
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ShapeMismatchError(f"camera {camera.name!r}: uv must be (N, 2), got shape {uv.shape}")
    points = np.full((uv.shape[0], 3), np.nan)
    if uv.shape[0] == 0:
        return points, np.zeros(0, dtype=bool)
    z = sample_depth(uv, depth, max_depth)
    valid = np.isfinite(z)
    if valid.any():
        points[valid] = _lift(uv[valid, 0], uv[valid, 1], z[valid], camera)
    return points, valid
