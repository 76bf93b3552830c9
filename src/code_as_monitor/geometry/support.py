"""The support plane: the scene's dominant plane (the table) from depth images.

Parts rest on it; carving (:mod:`code_as_monitor.geometry.carve`) never grows a part below it. World frame,
metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.geometry.solid import plane_ransac


@dataclass(frozen=True)
class SupportPlane:
    """The plane the parts rest on (the table): ``normal`` (3,) unit, pointing towards the cameras; ``offset``
    metres, ``normal @ p == offset`` on it; ``noise`` metres, the depth noise seen on it (1.4826 x MAD)."""

    normal: np.ndarray
    offset: float
    noise: float = 0.0


def support_plane(views: Sequence[tuple[np.ndarray, CameraModel]], max_depth: float = 5.0, samples: int = 3000,
                  tol: float = 0.006, rng: np.random.Generator | None = None) -> SupportPlane | None:
    """The scene's dominant plane (the table) from depth images, or None when no plane holds a fifth of the
    sampled points.

    Args:
        views: ``(depth (H, W) metres, camera)`` per view.
        max_depth: metres; readings beyond are ignored.
        samples: pixels sampled per view.
        tol: metres; RANSAC inlier distance.
    """
    from code_as_monitor.geometry.backproject import _lift, valid_depth

    rng = rng or np.random.default_rng(0)
    pts = []
    for depth, cam in views:
        d = np.asarray(depth)
        H, W = d.shape
        flat = rng.integers(0, H * W, size=samples)
        r, c = flat // W, flat % W
        z = d[r, c].astype(np.float64)
        ok = valid_depth(z, max_depth)
        if ok.any():
            pts.append(_lift(c[ok].astype(np.float64), r[ok].astype(np.float64), z[ok], cam))
    if not pts:
        return None
    P = np.vstack(pts)
    if len(P) < 50:
        return None
    n, inl = plane_ransac(P, tol, 96, rng)
    if inl.mean() < 0.2:
        return None
    cams = np.mean([cam.position for _, cam in views], axis=0)
    r = P[inl] @ n
    off = float(np.median(r))
    noise = float(1.4826 * np.median(np.abs(r - off)))
    if cams @ n < off:
        n, off = -n, -off
    return SupportPlane(n, off, noise)


__all__ = ["SupportPlane", "support_plane"]
