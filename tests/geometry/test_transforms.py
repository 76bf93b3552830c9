from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import GeometryError
from code_as_monitor.geometry import compose, invert, make_transform, rotation_about, transform_points


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    return make_transform(rotation_about(rng.normal(size=3), rng.uniform(-np.pi, np.pi)), rng.normal(size=3))


def test_rotation_about_is_right_handed_and_orthonormal() -> None:
    R = rotation_about([0, 0, 1], np.pi / 2)
    np.testing.assert_allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-12)
    R = rotation_about([1.0, 2.0, -0.5], 0.7)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_compose_invert_round_trip() -> None:
    rng = np.random.default_rng(0)
    A, B = _random_pose(rng), _random_pose(rng)
    np.testing.assert_allclose(compose(A, invert(A)), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(invert(compose(A, B)), compose(invert(B), invert(A)), atol=1e-12)
    np.testing.assert_allclose(compose(), np.eye(4))


def test_transform_points_matches_homogeneous_product() -> None:
    rng = np.random.default_rng(1)
    T = _random_pose(rng)
    P = rng.normal(size=(5, 3))
    expected = (T @ np.c_[P, np.ones(5)].T).T[:, :3]
    np.testing.assert_allclose(transform_points(T, P), expected, atol=1e-12)
    np.testing.assert_allclose(transform_points(T, P[0]), expected[0], atol=1e-12)
    # T_a_b then T_b_c equals T_a_c
    B = _random_pose(rng)
    np.testing.assert_allclose(transform_points(T, transform_points(B, P)), transform_points(compose(T, B), P))


def test_bad_transforms_are_named() -> None:
    with pytest.raises(GeometryError, match="not rigid"):
        invert(np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(GeometryError, match="4x4"):
        compose(np.eye(3))
    with pytest.raises(GeometryError, match="rotation must be 3x3"):
        make_transform(np.eye(2))
    with pytest.raises(GeometryError, match="not rigid"):
        make_transform(np.diag([1.0, 1.0, -1.0]))  # a reflection
    with pytest.raises(GeometryError, match="zero length"):
        rotation_about([0, 0, 0], 1.0)
    with pytest.raises(GeometryError, match="points must be"):
        transform_points(np.eye(4), np.zeros((4, 2)))


def test_kabsch_recovers_a_rigid_motion_and_never_a_reflection():
    from code_as_monitor.geometry.transforms import kabsch

    rng = np.random.default_rng(0)
    src = rng.normal(size=(12, 3))
    R0 = rotation_about(np.array([1.0, 2.0, 0.5]), 1.1)
    t0 = np.array([0.3, -0.2, 0.05])
    R, t, rms = kabsch(src, src @ R0.T + t0)
    assert np.allclose(R, R0, atol=1e-9) and np.allclose(t, t0, atol=1e-9) and rms < 1e-9
    mirrored = src * np.array([1.0, 1.0, -1.0])  # no rotation maps a cloud onto its mirror image
    R, _, rms = kabsch(src, mirrored)
    assert np.isclose(np.linalg.det(R), 1.0) and rms > 0.1


def test_cross_gives_numpys_values_for_pairs_and_rows() -> None:
    from code_as_monitor.geometry.transforms import cross

    rng = np.random.default_rng(11)
    A, B = rng.normal(size=(500, 3)), rng.normal(size=(500, 3)) * 1e-3
    assert np.array_equal(cross(A, B), np.cross(A, B))
    assert np.array_equal(cross(A, B[:1]), np.cross(A, B[:1]))  # one row against many
    for a, b in zip(A[:50], B[:50]):
        got = cross(a, b)
        assert got.shape == (3,) and np.array_equal(got, np.cross(a, b))
    assert np.array_equal(cross(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])), [0.0, 0.0, 1.0])
