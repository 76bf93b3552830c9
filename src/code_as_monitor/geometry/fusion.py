"""Multi-view fusion, voxel-grid downsampling and statistical outlier removal of point clouds.

Every cloud is an (N, 3) float array in the world frame, metres.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from code_as_monitor.core.errors import GeometryError, ShapeMismatchError
from code_as_monitor.geometry.stats import median


def _as_cloud(points: np.ndarray, what: str = "points") -> np.ndarray:
    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ShapeMismatchError(f"{what} must be (N, 3), got shape {P.shape}")
    return P


def fuse_points(clouds: Sequence[np.ndarray]) -> np.ndarray:
    """Concatenate per-view world clouds (N_i, 3) into one (N, 3) cloud, dropping non-finite rows.

    The views are already in the common world frame (back-projection applied ``T_world_cam``), so
    fusion is a concatenation; density differences between views are evened out later by
    :func:`voxel_downsample`.
    """
    parts = [_as_cloud(c, f"cloud #{i}") for i, c in enumerate(clouds)]
    if not parts:
        return np.empty((0, 3), dtype=np.float64)
    P = np.concatenate(parts, axis=0)
    return P[np.all(np.isfinite(P), axis=1)]


def voxel_keys(points: np.ndarray, voxel_size: float, origin: np.ndarray | None = None) -> np.ndarray:
    """(N,) int64 id of the voxel (edge ``voxel_size`` metres) of each point.

    The grid is anchored at ``origin`` (default the world origin, so the grid does not move with the
    cloud). Two points share an id exactly when they fall in the same voxel.
    """
    P = _as_cloud(points)
    if not voxel_size > 0:
        raise GeometryError(f"voxel_size must be > 0, got {voxel_size!r}")
    o = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    ijk = np.floor((P - o) / voxel_size).astype(np.int64)
    ijk -= ijk.min(axis=0) if len(ijk) else 0
    dims = ijk.max(axis=0) + 1 if len(ijk) else np.ones(3, np.int64)
    return (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]


def voxel_downsample(points: np.ndarray, voxel_size: float) -> tuple[np.ndarray, np.ndarray]:
    """One point per occupied voxel: the mean of the points inside it.

    Args:
        points: (N, 3) world, metres.
        voxel_size: voxel edge, metres.
    Returns:
        centres: (M, 3) voxel means, metres (M <= N), in increasing voxel-id order.
        counts: (M,) number of input points in each voxel.
    """
    P = _as_cloud(points)
    if len(P) == 0:
        return P.copy(), np.zeros(0, dtype=np.int64)
    keys = voxel_keys(P, voxel_size)
    _, inv, counts = np.unique(keys, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    out = np.empty((len(counts), 3))
    for i in range(3):
        out[:, i] = np.bincount(inv, weights=P[:, i], minlength=len(counts)) / counts
    return out, counts


def remove_outliers(points: np.ndarray, k: int = 16, std_ratio: float = 2.0) -> np.ndarray:
    """Statistical outlier removal.

    For each point, the mean distance to its ``k`` nearest neighbours is computed; points whose mean
    distance exceeds ``mean + std_ratio * std`` of those values over the cloud are dropped.

    Args:
        points: (N, 3) world, metres.
        k: neighbours per point (>= 1).
        std_ratio: threshold in standard deviations (> 0).
    Returns:
        (M, 3) kept points, original order (the input unchanged when N <= k).
    """
    from scipy.spatial import cKDTree

    P = _as_cloud(points)
    if k < 1:
        raise GeometryError(f"remove_outliers: k must be >= 1, got {k!r}")
    if not std_ratio > 0:
        raise GeometryError(f"remove_outliers: std_ratio must be > 0, got {std_ratio!r}")
    if len(P) <= k:
        return P.copy()
    d, _ = cKDTree(P).query(P, k=k + 1)
    mean_d = d[:, 1:].mean(axis=1)  # column 0 is the point itself
    thr = mean_d.mean() + std_ratio * mean_d.std()
    return P[mean_d <= thr]


def remove_isolated(points: np.ndarray, radius: float, min_neighbours: int = 3) -> np.ndarray:
    """Drop the points (N, 3) with fewer than ``min_neighbours`` other points within ``radius`` metres, or
    within 2.5 times the cloud's median nearest-neighbour spacing when that is larger (a sparse cloud, say
    from a low-resolution camera, is not all isolated).

    Unlike :func:`remove_outliers` it keeps thin but connected structures (a box's narrow side face seen at a
    grazing angle, two voxels wide), whose points have fewer neighbours than those of a broad face yet are
    real; what it drops are stray readings (a wrong depth at a mask's edge, sensor outliers). Original order.
    """
    from scipy.spatial import cKDTree

    P = _as_cloud(points)
    if not radius > 0:
        raise GeometryError(f"remove_isolated: radius must be > 0, got {radius!r}")
    if len(P) <= min_neighbours:
        return P.copy()
    tree = cKDTree(P)
    spacing = float(median(tree.query(P[:: max(1, len(P) // 256)], k=2)[0][:, 1]))
    r = max(radius, 2.5 * spacing)
    keep = _surely_connected(P, r, min_neighbours)
    ask = np.flatnonzero(~keep)
    if len(ask):
        # the (min_neighbours + 1)-th nearest, the point itself first, within r (the bound is strict, so its next
        # float): the same test as counting every point in the ball, at the cost of a few neighbours
        d, _ = tree.query(P[ask], k=min_neighbours + 1, distance_upper_bound=float(np.nextafter(r, np.inf)))
        keep[ask] = np.isfinite(d[:, min_neighbours])
    return P[keep]


_FACE_STEPS = np.array([[0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])


def _surely_connected(P: np.ndarray, r: float, k: int) -> np.ndarray:
    """(N,) bool: points of ``P`` (N, 3) that certainly have ``k`` others within ``r`` metres, counted on a grid of
    cells ``r / 2.5`` wide: the others in the point's cell and the six that share a face with it, all within
    sqrt(6) cells (0.98 r) of it. False says nothing (the neighbours may lie in other cells)."""
    ijk = np.floor(P / (r / 2.5)).astype(np.int64)
    ijk -= ijk.min(axis=0) - 1  # >= 1: a neighbouring cell's index is >= 0
    dims = ijk.max(axis=0) + 2
    key = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    cells, counts = np.unique(key, return_counts=True)
    n = np.full(len(P), -1)  # minus the point itself
    for step in _FACE_STEPS:
        q = key + (step[0] * dims[1] + step[1]) * dims[2] + step[2]
        i = np.minimum(np.searchsorted(cells, q), len(cells) - 1)
        n += np.where(cells[i] == q, counts[i], 0)
    return n >= k
