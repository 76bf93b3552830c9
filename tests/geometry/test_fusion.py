from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import GeometryError, ShapeMismatchError
from code_as_monitor.geometry import fuse_points, remove_outliers, voxel_downsample
from code_as_monitor.geometry.fusion import remove_isolated, voxel_keys


def test_fuse_points_concatenates_and_drops_non_finite() -> None:
    a = np.zeros((3, 3))
    b = np.ones((2, 3))
    b[1, 0] = np.nan
    P = fuse_points([a, b])
    assert P.shape == (4, 3)
    assert fuse_points([]).shape == (0, 3)
    with pytest.raises(ShapeMismatchError, match="cloud #1"):
        fuse_points([a, np.zeros((2, 2))])


def test_voxel_downsample_means_and_counts() -> None:
    P = np.array([[0.001, 0.001, 0.001], [0.003, 0.003, 0.003], [0.012, 0.0, 0.0], [0.5, 0.5, 0.5]])
    Q, counts = voxel_downsample(P, 0.01)
    assert counts.sum() == 4 and len(Q) == 3
    np.testing.assert_allclose(Q[np.argmax(counts)], [0.002, 0.002, 0.002])
    keys = voxel_keys(P, 0.01)
    assert keys[0] == keys[1] != keys[2]
    with pytest.raises(GeometryError, match="voxel_size"):
        voxel_downsample(P, 0.0)
    Q, counts = voxel_downsample(np.zeros((0, 3)), 0.01)
    assert Q.shape == (0, 3) and counts.shape == (0,)


def test_remove_outliers_drops_isolated_points_keeps_surface() -> None:
    rng = np.random.default_rng(0)
    g = np.linspace(0.0, 0.2, 40)
    X, Y = np.meshgrid(g, g)
    plane = np.c_[X.ravel(), Y.ravel(), rng.normal(0, 0.001, X.size)]
    outliers = rng.uniform([-0.5, -0.5, 0.1], [0.7, 0.7, 0.8], size=(30, 3))
    kept = remove_outliers(np.vstack([plane, outliers]), k=16, std_ratio=2.0)
    far = (kept[:, 2] > 0.05).sum()
    assert far <= 3  # one pass of the statistical filter; DBSCAN in the element fit catches the rest
    assert len(kept) >= 0.9 * len(plane)


def test_remove_outliers_edge_cases() -> None:
    P = np.random.default_rng(1).normal(size=(10, 3))
    np.testing.assert_array_equal(remove_outliers(P, k=16), P)  # too few points to judge
    with pytest.raises(GeometryError, match="k must be"):
        remove_outliers(P, k=0)
    with pytest.raises(GeometryError, match="std_ratio"):
        remove_outliers(P, std_ratio=0.0)
    with pytest.raises(ShapeMismatchError):
        remove_outliers(np.zeros((5, 2)))


def _isolated_by_counting(P: np.ndarray, radius: float, k: int) -> np.ndarray:
    """Reference: keep the points with at least ``k`` others within ``radius`` (or 2.5 median spacings), counted
    one by one."""
    from scipy.spatial import cKDTree

    tree = cKDTree(P)
    spacing = float(np.median(tree.query(P[:: max(1, len(P) // 256)], k=2)[0][:, 1]))
    r = max(radius, 2.5 * spacing)
    dist = np.linalg.norm(P[:, None, :] - P[None, :, :], axis=2)
    others = (dist <= r).sum(axis=1) - 1  # minus the point itself
    return P[others >= k]


def test_remove_isolated_keeps_exactly_the_points_with_enough_neighbours() -> None:
    rng = np.random.default_rng(3)
    plane = np.c_[rng.uniform(0, 0.1, (600, 2)), rng.normal(0, 0.001, 600)]
    strays = rng.uniform(-0.3, 0.3, (25, 3))
    r = 2.0 ** -7  # exact in binary, as are the distances below: three neighbours exactly at the radius count
    star = np.array([[1.0, 1.0, 1.0], [1.0 + r, 1.0, 1.0], [1.0, 1.0 + r, 1.0], [1.0, 1.0, 1.0 + r]])
    dense = np.c_[rng.uniform(0, 0.04, (600, 2)), np.zeros(600)]  # median spacing well under r / 2.5
    for P, radius, k in ((np.r_[plane, strays], 0.01, 3), (np.r_[plane, strays], 0.02, 6), (np.r_[dense, star], r, 3),
                         (np.r_[dense, star], r, 1), (strays, 0.05, 1)):
        got = remove_isolated(P, radius, k)
        want = _isolated_by_counting(P, radius, k)
        assert np.array_equal(got, want), (len(P), radius, k, len(got), len(want))
    assert 0 < len(remove_isolated(np.r_[plane, strays], 0.01, 3)) < 625
    assert len(remove_isolated(np.r_[dense, star], r, 3)) == 601  # the star's centre kept, its arms not
