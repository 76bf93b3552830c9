"""The monitor helpers (geometry/helpers.py): values on hand-checked cases, points vs elements."""

from __future__ import annotations

import math

import numpy as np
import pytest

from code_as_monitor.geometry import helpers as h

SQUARE = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])


def test_registry_lists_every_helper() -> None:
    assert set(h.MONITOR_HELPERS) == {
        "distance", "horizontal_distance", "centroid", "direction", "normal", "angle_between",
        "angle_to_vertical", "point_in_polygon", "count_in_polygon", "signed_height",
        "point_above_surface", "displacement",
    }
    assert all(callable(f) for f in h.MONITOR_HELPERS.values())


def test_distance_and_centroid_accept_points_or_elements() -> None:
    assert h.distance(np.array([0.0, 0.0, 0.0]), np.array([3.0, 4.0, 0.0])) == pytest.approx(5.0)
    assert h.distance(SQUARE, np.array([[0.5, 0.5, 2.0]])) == pytest.approx(2.0)  # element centroid
    assert h.horizontal_distance(np.array([0.0, 0.0, 5.0]), np.array([3.0, 4.0, -1.0])) == pytest.approx(5.0)
    np.testing.assert_allclose(h.centroid(SQUARE), [0.5, 0.5, 0.0])
    assert isinstance(h.distance(SQUARE, SQUARE), float)


def test_direction() -> None:
    L = np.array([[1.0, 1.0, 1.0], [1.0, 1.0, 3.0]])
    np.testing.assert_allclose(h.direction(L), [0, 0, 1])
    np.testing.assert_allclose(h.direction(L[::-1]), [0, 0, -1])  # first -> second point
    np.testing.assert_allclose(h.direction(L[:1]), [0, 0, 1])  # degenerate: z by convention
    np.testing.assert_allclose(h.direction(np.zeros((2, 3))), [0, 0, 1])


def test_normal_is_oriented_up() -> None:
    np.testing.assert_allclose(h.normal(SQUARE), [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(h.normal(SQUARE[::-1]), [0, 0, 1], atol=1e-12)
    wall = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 1.0]])
    n = h.normal(wall)
    assert abs(n[0]) == pytest.approx(1.0)
    np.testing.assert_allclose(h.normal(SQUARE[:2]), [0, 0, 1])


def test_angles() -> None:
    assert h.angle_between([1, 0, 0], [0, 1, 0]) == pytest.approx(math.pi / 2)
    assert h.angle_between([1, 0, 0], [-2, 0, 0]) == pytest.approx(math.pi)
    assert h.angle_between([0, 0, 0], [1, 0, 0]) == 0.0
    assert h.angle_to_vertical([0, 0, -1]) == pytest.approx(0.0)  # unsigned
    assert h.angle_to_vertical([1, 0, 1]) == pytest.approx(math.pi / 4)
    assert h.angle_to_vertical([1, 0, -1]) == pytest.approx(math.pi / 4)
    assert h.angle_to_vertical([1, 0, 0]) == pytest.approx(math.pi / 2)


def test_point_in_polygon_any_corner_order() -> None:
    crossed = SQUARE[[0, 2, 1, 3]]  # a self-intersecting order of the same corners
    for poly in (SQUARE, SQUARE[::-1], crossed):
        assert h.point_in_polygon(np.array([0.5, 0.5, 7.0]), poly)  # z ignored
        assert not h.point_in_polygon(np.array([1.5, 0.5, 0.0]), poly)
    assert h.point_in_polygon(np.array([[0.4, 0.4, 0.0], [0.6, 0.6, 0.0]]), SQUARE)  # element centroid
    assert not h.point_in_polygon(np.array([0.5, 0.5, 0.0]), SQUARE[:2])
    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert h.point_in_polygon(np.array([0.2, 0.2, 0.0]), tri)
    assert not h.point_in_polygon(np.array([0.6, 0.6, 0.0]), tri)


def test_count_in_polygon() -> None:
    pts = np.array([[0.5, 0.5, 0.0], [0.1, 0.9, 1.0], [2.0, 2.0, 0.0]])
    assert h.count_in_polygon(pts, SQUARE) == 2
    assert h.count_in_polygon([pts[0], pts[2][None]], SQUARE) == 1  # a list of points/elements
    assert h.count_in_polygon([], SQUARE) == 0


def test_signed_height_and_point_above_surface() -> None:
    top = SQUARE + np.array([0.0, 0.0, 0.1])
    assert h.signed_height(np.array([0.5, 0.5, 0.3]), top) == pytest.approx(0.2)
    assert h.signed_height(np.array([0.5, 0.5, 0.0]), top) == pytest.approx(-0.1)
    assert h.signed_height(np.array([0.5, 0.5, 0.3]), top[::-1]) == pytest.approx(0.2)  # normal is up either way
    assert h.point_above_surface(np.array([0.5, 0.5, 0.3]), top)
    assert not h.point_above_surface(np.array([0.5, 0.5, 0.3]), top, margin=0.25)
    assert not h.point_above_surface(np.array([1.5, 0.5, 0.3]), top)


def test_displacement() -> None:
    H = np.zeros((5, 2, 3))
    H[:, :, 0] = np.arange(5)[:, None] * 0.1
    H[-1, :, 1] = 0.3  # the last frame also moved in y
    assert h.displacement(H) == pytest.approx(0.5)
    assert h.displacement(H[:1]) == 0.0
    assert h.displacement(np.zeros((4, 3))) == 0.0  # not a history


# --- the fast paths against the plain NumPy definitions -------------------------------------------
def _ref_normal(S: np.ndarray) -> np.ndarray:
    _, _, vt = np.linalg.svd(S - S.mean(axis=0))
    n = vt[-1]
    return -n if n[2] < 0 else n


def _ref_in_polygon(p: np.ndarray, poly: np.ndarray) -> bool:
    """Ray casting with NumPy corners sorted by np.argsort of their angle (the definition the helper keeps)."""
    P = poly[:, :2]
    c = P.mean(axis=0)
    P = P[np.argsort(np.arctan2(P[:, 1] - c[1], P[:, 0] - c[0]))]
    x, y = p.reshape(-1, 3).mean(axis=0)[:2]
    inside, j = False, len(P) - 1
    for i in range(len(P)):
        (xi, yi), (xj, yj) = P[i], P[j]
        if (yi > y) != (yj > y) and x < xi + (y - yi) * (xj - xi) / (yj - yi):
            inside = not inside
        j = i
    return inside


@pytest.mark.parametrize("seed", range(5))
def test_fast_paths_agree_with_the_numpy_definitions(seed: int) -> None:
    """The helpers avoid NumPy's Python wrappers (they run every frame in the sandbox): same values."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        k = int(rng.integers(1, 7))
        A = rng.normal(0.0, 0.1, (k, 3))
        B = rng.normal(0.0, 0.1, (int(rng.integers(1, 5)), 3))
        assert h.distance(A, B) == pytest.approx(float(np.linalg.norm(A.mean(0) - B.mean(0))), rel=1e-12)
        np.testing.assert_allclose(h.centroid(A), A.mean(axis=0), rtol=0, atol=1e-15)
        u, v = rng.normal(size=3), rng.normal(size=3)
        ref = math.acos(np.clip(np.dot(u, v) / (np.linalg.norm(u) * np.linalg.norm(v)), -1, 1))
        assert h.angle_between(u, v) == pytest.approx(ref, abs=1e-12)
        H = rng.normal(0.0, 0.1, (int(rng.integers(2, 9)), k, 3))
        assert h.displacement(H) == pytest.approx(float(np.linalg.norm(H[-1].mean(0) - H[0].mean(0))), rel=1e-12)
        if k >= 3:
            n = h.normal(A)
            np.testing.assert_allclose(n, _ref_normal(A), atol=1e-9)  # a plane's normal, oriented z >= 0
            assert n[2] >= 0 and np.linalg.norm(n) == pytest.approx(1.0)
            q = rng.normal(0.0, 0.1, (1, 3))
            assert h.point_in_polygon(q, A) == _ref_in_polygon(q, A)
            pts = rng.normal(0.0, 0.1, (6, 3))
            assert h.count_in_polygon(pts, A) == sum(_ref_in_polygon(x, A) for x in pts)
            ref_h = float(np.dot(q.mean(0) - A.mean(0), _ref_normal(A)))
            assert h.signed_height(q, A) == pytest.approx(ref_h, abs=1e-12)


def test_normal_of_three_collinear_points_falls_back_to_the_fit() -> None:
    S = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    n = h.normal(S)
    assert np.linalg.norm(n) == pytest.approx(1.0) and abs(n[0]) < 1e-9  # some normal of the line, unit length
