"""Pieces of the LK tracker (:mod:`.lk`): the per-view track state and the NaN-aware fusion over views (the rigid
fit is :func:`code_as_monitor.geometry.transforms.kabsch`). Points are world metres; pixels are (u, v) float32.
"""

from __future__ import annotations

import warnings

import numpy as np

from code_as_monitor.core.observation import View


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
        self.chroma = np.full((m, 2), np.nan)  # (r, g) chromaticity at the anchor when it was seeded; NaN = unknown

    def make_key(self) -> None:
        """Make the current frame the key frame the templates come from."""
        self.key = self.gray
        self.key_uv[:] = self.uv
        self.rekey = False


def gray_of(view: View) -> np.ndarray:
    """(H, W) uint8 grayscale of a view's RGB."""
    import cv2

    return cv2.cvtColor(view.rgb, cv2.COLOR_RGB2GRAY)


def chroma_at(rgb: np.ndarray, uv: np.ndarray, min_sum: float) -> np.ndarray:
    """(N, 2) chromaticity (r, g) = (R, G) / (R + G + B) of the 3x3 mean colour around pixels ``uv`` (N, 2).

    Chromaticity does not change with a surface's shading, so it tells one coloured object from another where
    their grey levels (what LK matches) are alike. NaN where the pixel is outside the image or darker than
    ``min_sum`` (R + G + B, 0-765: too dark for a colour).
    """
    h, w = rgb.shape[:2]
    out = np.full((len(uv), 2), np.nan)
    if not len(uv):
        return out
    ok = np.isfinite(uv).all(axis=1)
    ui = np.clip(np.rint(np.nan_to_num(uv[:, 0])).astype(int), 1, w - 2)
    vi = np.clip(np.rint(np.nan_to_num(uv[:, 1])).astype(int), 1, h - 2)
    acc = np.zeros((len(uv), 3))
    for dv in (-1, 0, 1):
        for du in (-1, 0, 1):
            acc += rgb[vi + dv, ui + du].astype(np.float64)
    acc /= 9.0
    s = acc.sum(axis=1)
    ok &= s >= max(min_sum, 1e-6)
    out[ok] = acc[ok, :2] / s[ok, None]
    return out


def chroma_kept(seeded: np.ndarray, now: np.ndarray, max_change: float) -> np.ndarray:
    """(N,) bool: the chromaticity ``now`` (N, 2) is within ``max_change`` of ``seeded`` (N, 2); True where
    either is unknown (NaN: too dark to tell) or the test is off (``max_change`` 0)."""
    if max_change <= 0:
        return np.ones(len(now), dtype=bool)
    d = np.linalg.norm(now - seeded, axis=1)
    return ~(d > max_change)  # NaN compares False: unknown is kept


def views_agree(per_view: np.ndarray, observed: np.ndarray, tol: float) -> np.ndarray:
    """(M,) bool: the views that observed each point put it within ``tol`` metres of one another.

    Args:
        per_view: (V, M, 3) each view's estimate of each point, world metres (NaN where not observed).
        observed: (V, M) bool, finite estimates.
        tol: metres; 0 disables the test (all True).
    Two views that disagree by more than the trackers' own error cannot both be right, and which one slid (onto
    an occluder's edge, another object) is not known: the point is not observed this frame.
    """
    m = per_view.shape[1]
    if tol <= 0 or per_view.shape[0] < 2:
        return np.ones(m, dtype=bool)
    P = np.where(observed[:, :, None], per_view, 0.0)
    d = np.linalg.norm(P[:, None] - P[None, :], axis=-1)  # (V, V, M)
    both = observed[:, None] & observed[None, :]
    return ~np.any(both & (d > tol), axis=(0, 1))


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
