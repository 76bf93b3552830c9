"""A part's point cloud from its masks in several views: lift, fuse, downsample, filter, keep the dense clusters.

Pipeline (all clouds (N, 3), world frame, metres):

1. back-project every view's mask with its depth (:func:`~.backproject.backproject_mask`) and fuse;
2. voxel-downsample on a fine grid (:func:`fine_voxel_size`: 4 mm, coarser for big parts) so that every later
   stage sees an evenly spread cloud of bounded size, whatever the image resolution;
3. isolated points dropped (:func:`~.fusion.remove_isolated`: fewer than 3 others within 2.5 voxels);
4. the connected clusters of the occupancy grid (:func:`dense_clusters`) split off debris.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import MAX_CLOUD_POINTS
from code_as_monitor.core.errors import GeometryError, NoValidDepthError
from code_as_monitor.geometry.backproject import DEFAULT_MAX_DEPTH, backproject_mask
from code_as_monitor.geometry.fusion import fuse_points, remove_isolated, voxel_downsample
from code_as_monitor.geometry.stats import percentile

MIN_FINE_VOXEL = 0.004
"""Metres: the finest voxel of the downsampling grid."""
FINE_VOXELS_ACROSS = 100
"""The fine voxel is at least the part's robust extent divided by this (bounds the cloud size)."""

Observation3D = tuple[np.ndarray, np.ndarray, CameraModel]
"""``(mask (H, W) bool, depth (H, W) metres, camera)``: one view of one part."""


def fine_voxel_size(points: np.ndarray) -> float:
    """Fine downsampling voxel (metres) for a cloud (N, 3): max(4 mm, robust extent / 100)."""
    if len(points) < 2:
        return MIN_FINE_VOXEL
    lo, hi = percentile(np.asarray(points, dtype=np.float64), [2.0, 98.0], axis=0)
    return float(max(MIN_FINE_VOXEL, (hi - lo).max() / FINE_VOXELS_ACROSS))


def dense_clusters(Q: np.ndarray, voxel: float, min_cluster_frac: float = 0.1) -> np.ndarray:
    """Rows of ``Q`` (M, 3) in its dense clusters: every connected cluster at least ``min_cluster_frac`` of the
    largest (debris and stray fragments of a mask drop out).

    Clusters are the 26-connected components of the occupancy grid of voxel ``2 * voxel`` (points less than
    about two to four fine voxels apart are connected; the grid is coarsened further for very long clouds so
    that it holds at most about 2e6 cells). Returns all of ``Q`` when it has fewer than 8 rows.
    """
    if len(Q) < 8:
        return Q
    from scipy import ndimage

    g = 2.0 * voxel
    lo = Q.min(axis=0)
    span = Q.max(axis=0) - lo
    while np.prod(np.floor(span / g) + 1) > 2e6:
        g *= 1.5
    ijk = np.floor((Q - lo) / g).astype(np.int64)
    occ = np.zeros(tuple(ijk.max(axis=0) + 1), dtype=bool)
    occ[ijk[:, 0], ijk[:, 1], ijk[:, 2]] = True
    lab, n = ndimage.label(occ, structure=np.ones((3, 3, 3), dtype=bool))
    if n <= 1:
        return Q
    labels = lab[ijk[:, 0], ijk[:, 1], ijk[:, 2]]
    sizes = np.bincount(labels)
    sizes[0] = 0
    keep = sizes >= min_cluster_frac * sizes.max()
    return Q[keep[labels]]


def part_cloud(
    observations: Sequence[Observation3D],
    max_depth: float = DEFAULT_MAX_DEPTH,
    name: str = "part",
) -> tuple[np.ndarray, float]:
    """Fused, downsampled, filtered cloud (M, 3) of one part over its views, and the voxel used.

    Raises:
        ShapeMismatchError: a mask, depth and camera disagree in size.
        NoValidDepthError: no view has a mask pixel with a valid depth.
    """
    Q, vs, _ = part_cloud_views(observations, max_depth, name)
    return Q, vs


def part_cloud_views(
    observations: Sequence[Observation3D], max_depth: float = DEFAULT_MAX_DEPTH, name: str = "part",
) -> tuple[np.ndarray, float, int]:
    """:func:`part_cloud` plus the number of views that gave at least one valid point."""
    clouds = [backproject_mask(m, d, cam, max_depth, allow_empty=True) for m, d, cam in observations]
    return fuse_part(clouds, [cam.name for _, _, cam in observations], name)


def fuse_part(clouds: Sequence[np.ndarray], view_names: Sequence[str], name: str = "part"
              ) -> tuple[np.ndarray, float, int]:
    """Fuse per-view world clouds (N_i, 3) of one part: (cloud (M, 3), voxel metres, views that gave points).

    Raises:
        NoValidDepthError: every cloud is empty (the message names the views).
    """
    P = fuse_points(clouds)
    if len(P) == 0:
        names = ", ".join(repr(n) for n in view_names) or "(none)"
        raise NoValidDepthError(f"{name}: no mask pixel with a valid depth in any view ({names})")
    vs = fine_voxel_size(P)
    Q, _ = voxel_downsample(P, vs)
    return remove_isolated(Q, 2.5 * vs, 3), vs, sum(len(c) > 0 for c in clouds)


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
        Q, vs, _ = part_cloud_views(observations, max_depth, "cloud")
    except NoValidDepthError:
        return np.empty((0, 3))
    return cap_cloud(Q, max_points, vs)
