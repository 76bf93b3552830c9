from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import GeometryError, ShapeMismatchError
from code_as_monitor.geometry import fuse_points, remove_outliers, voxel_downsample
from code_as_monitor.geometry.fusion import voxel_keys


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
