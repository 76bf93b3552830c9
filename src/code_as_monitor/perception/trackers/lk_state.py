"""Pieces of the LK tracker (:mod:`.lk`): the per-view track state, the rigid (Kabsch) fit, and the
NaN-aware fusion over views. Points are world metres; pixels are (u, v) float32.
"""

from __future__ import annotations

import warnings

import numpy as np

from code_as_monitor.core.observation import Observation, View


def kabsch(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares rigid transform with ``dst ≈ src @ R.T + t``.

    Args:
        src, dst: (n, 3) corresponding points, n >= 3.
    Returns:
        R (3, 3) proper rotation, t (3,), RMS residual (metres).
    """
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    U, _, Vt = np.linalg.svd((src - cs).T @ (dst - cd))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    t = cd - cs @ R.T
    rms = float(np.sqrt(((src @ R.T + t - dst) ** 2).sum(axis=1).mean()))
    return R, t, rms


class ViewState:
    """Per-view tracking state over the M flattened element points."""

    def __init__(self, m: int) -> None:
        self.gray: np.ndarray | None = None  # (H, W) uint8, current frame
        self.key: np.ndarray | None = None  # (H, W) uint8, key frame the templates come from
        self.key_uv = np.zeros((m, 2), dtype=np.float32)  # anchor pixels in the key frame
        self.rekey = True  # make the current frame the key frame at the end of this step
        self.uv = np.zeros((m, 2), dtype=np.float32)  # anchor pixels, current frame
        self.active = np.zeros(m, dtype=bool)  # tracked in this view
        self.offset = np.zeros((m, 3))  # world-frame offset point - lift(anchor)
        self.xyz = np.full((m, 3), np.nan)  # lift(anchor) at its last update, world metres
        self.z = np.zeros(m)  # depth reading at the anchor last frame, metres

    def make_key(self) -> None:
        """Make the current frame the key frame the templates come from."""
        self.key = self.gray
        self.key_uv[:] = self.uv
        self.rekey = False


def gray_of(view: View) -> np.ndarray:
    """(H, W) uint8 grayscale of a view's RGB."""
    import cv2

    return cv2.cvtColor(view.rgb, cv2.COLOR_RGB2GRAY)


def cam_z(view: View, pts: np.ndarray) -> np.ndarray:
    """(N,) depth along the view's optical axis of world points (N, 3), metres."""
    T = view.camera.T_world_cam
    return (pts - T[:3, 3]) @ T[:3, 2]


def inside(view: View, border: int, uv: np.ndarray) -> np.ndarray:
    """(N,) bool: finite pixels (N, 2) at least ``border`` pixels inside the view's image."""
    cam = view.camera
    return (
        np.isfinite(uv).all(axis=1)
        & (uv[:, 0] >= border) & (uv[:, 0] <= cam.width - 1 - border)
        & (uv[:, 1] >= border) & (uv[:, 1] <= cam.height - 1 - border)
    )


def tip_of(obs: Observation) -> np.ndarray | None:
    """The end-effector tip (3,) in the world frame, or None without robot state."""
    if obs.robot is None:
        return None
    p = obs.robot.ee_points.get("tip")
    return np.asarray(p if p is not None else obs.robot.ee_pose[:3, 3], dtype=np.float64).reshape(3)


def slots(sl: slice, k: int) -> slice:
    """The anchor-slot slice of the point slice ``sl`` with ``k`` anchors per point."""
    return slice(sl.start * k, sl.stop * k)


def nanmedian_axis(a: np.ndarray, axis: int) -> np.ndarray:
    """``np.nanmedian`` without the all-NaN warning (all-NaN slices give NaN)."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(a, axis=axis)


def nanmean(est: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """Mean over views (axis 0) of (V, M, 3) estimates ignoring NaN; NaN where no view observed."""
    n = observed.sum(axis=0)
    s = np.where(observed[:, :, None], est, 0.0).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return s / n[:, None]
