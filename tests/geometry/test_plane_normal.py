"""normal(): the closed-form least-squares normal agrees with the SVD's on every kind of surface element,
and the SVD still decides where the closed form would be ill-conditioned or its sign ambiguous."""

from __future__ import annotations

import math

import numpy as np
import pytest

from code_as_monitor.geometry import helpers
from code_as_monitor.geometry.helpers import normal


def _svd_normal(S: np.ndarray) -> np.ndarray:
    _, _, vt = np.linalg.svd(S - S.mean(0), full_matrices=False)
    n = vt[-1]
    return -n if n[2] < 0 else n


def _surface(rng: np.random.Generator, k: int, noise: float) -> np.ndarray:
    """k points on a random plane (random tilt, size 1 cm - 1 m, anywhere on a 2 m table) plus noise."""
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    u = np.cross(n, rng.normal(size=3))
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    size = 10 ** rng.uniform(-2, 0)
    uv = rng.uniform(-size, size, (k, 2))
    return rng.uniform(-1, 1, 3) + uv[:, :1] * u + uv[:, 1:] * v + rng.normal(0, noise * size, (k, 3))


@pytest.mark.parametrize("k", [4, 5, 8, 30])
@pytest.mark.parametrize("noise", [0.0, 1e-3, 0.05])
def test_closed_form_matches_svd_on_random_planes(k: int, noise: float) -> None:
    rng = np.random.default_rng(1000 * k + int(noise * 1e4))
    used = 0
    for _ in range(300):
        S = _surface(rng, k, noise)
        got, ref = normal(S), _svd_normal(S)
        used += helpers._least_squares_normal(S.tolist()) is not None
        assert got.shape == (3,) and got[2] >= 0
        assert abs(float(np.linalg.norm(got)) - 1.0) < 1e-12
        if abs(ref[2]) > 1e-3:  # away from vertical the sign is fixed: the vectors agree
            np.testing.assert_allclose(got, ref, atol=1e-9)
        else:  # near vertical: the same line through the origin
            assert abs(abs(float(got @ ref)) - 1.0) < 1e-9
    assert used > 250  # the fast path is the one that ran


def test_axis_aligned_and_tabletop_surfaces() -> None:
    square = np.array([[-0.02, -0.02, 0.0], [0.02, -0.02, 0.0], [0.02, 0.02, 0.0], [-0.02, 0.02, 0.0]])
    np.testing.assert_allclose(normal(square + np.array([0.3, 0.0, 0.23])), [0.0, 0.0, 1.0], atol=1e-12)
    c, s = math.cos(0.3), math.sin(0.3)
    tilted = square @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]])  # turned 0.3 rad about x
    np.testing.assert_allclose(normal(tilted), [0.0, -s, c], atol=1e-12)


def test_vertical_surface_is_left_to_the_svd_bit_for_bit() -> None:
    wall = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.1, 0.0, 0.2], [0.0, 0.0, 0.2]]) + np.array([0.4, 0.1, 0.05])
    assert helpers._least_squares_normal(wall.tolist()) is None
    np.testing.assert_array_equal(normal(wall), _svd_normal(wall))


@pytest.mark.parametrize("S", [
    np.zeros((4, 3)),  # one point four times
    np.array([[0.0, 0, 0], [0.1, 0, 0.1], [0.2, 0, 0.2], [0.3, 0, 0.3]]),  # collinear
    np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]),  # isotropic
])
def test_degenerate_point_sets_fall_back(S: np.ndarray) -> None:
    assert helpers._least_squares_normal(S.tolist()) is None
    n = normal(S)
    assert n.shape == (3,) and np.isfinite(n).all()


def test_nan_points_fall_back_to_the_svd() -> None:
    S = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, math.nan]])
    assert helpers._least_squares_normal(S.tolist()) is None
