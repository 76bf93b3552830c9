"""The analytic ray caster against hand-computed depths (it is the ground truth of the other tests)."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ElementError
from code_as_monitor.geometry.raycast import Box, Cylinder, Plane, cast
from code_as_monitor.geometry.synthetic import SyntheticScene, add_depth_noise


def _down_camera(height: float = 1.0, size: int = 41) -> CameraModel:
    """A camera straight above the origin looking down (z forward = world -z)."""
    return CameraModel.look_at("down", [0.0, 0.0, height], [0.0, 0.0, 0.0], size, size, 60.0, up=[0, 1, 0])


def test_plane_and_box_from_above() -> None:
    cam = _down_camera()
    box = Box(np.array([0.0, 0.0, 0.1]), np.array([0.1, 0.1, 0.1]))
    depth, index, face = cast([box, Plane(0.0, (0.0, 0.0), (2.0, 2.0))], cam)
    c = 20  # the principal point: the ray along the optical axis
    assert depth[c, c] == pytest.approx(0.8)  # box top at z = 0.2
    assert index[c, c] == 0 and face[c, c] == 4  # +z face
    assert depth[0, 0] == pytest.approx(1.0)  # plane z = 0; optical-axis depth is the height, not the ray length
    assert index[0, 0] == 1
    assert np.isfinite(depth).all()


def test_plane_bounds_and_misses() -> None:
    cam = _down_camera()
    depth, index, face = cast([Plane(0.0, (0.0, 0.0), (0.05, 0.05))], cam)
    assert np.isinf(depth[0, 0]) and index[0, 0] == -1 and face[0, 0] == -1
    assert depth[20, 20] == pytest.approx(1.0)


def test_cylinder_side_and_cap() -> None:
    cam = _down_camera(size=81)
    # a horizontal rod along x at height 0.3: the topmost side point is 0.3 + r
    rod = Cylinder(np.array([0.0, 0.0, 0.3]), np.array([1.0, 0.0, 0.0]), 0.02, 0.1)
    depth, _, face = cast([rod], cam)
    assert depth[40, 40] == pytest.approx(1.0 - 0.32)
    assert face[40, 40] == 0
    # standing upright: the +axis cap is seen
    post = Cylinder(np.array([0.0, 0.0, 0.3]), np.array([0.0, 0.0, 1.0]), 0.05, 0.1)
    depth, _, face = cast([post], cam)
    assert depth[40, 40] == pytest.approx(0.6) and face[40, 40] == 1
    np.testing.assert_allclose(post.ends(), [[0, 0, 0.2], [0, 0, 0.4]])


def test_box_faces_and_corners() -> None:
    box = Box(np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 0.3]))
    top = box.corners(4)
    np.testing.assert_allclose(top[:, 2], 3.3)
    # counter-clockwise seen from +z: positive shoelace area
    x, y = top[:, 0], top[:, 1]
    assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) == pytest.approx(0.08)
    np.testing.assert_allclose(box.face_normals()[4], [0, 0, 1])


def test_depth_noise_statistics() -> None:
    rng = np.random.default_rng(0)
    depth = np.ones((200, 200), dtype=np.float32)
    depth[:10] = 0.0  # missing stays missing
    mask = np.zeros_like(depth, dtype=bool)
    mask[50:150, 50:150] = True
    noisy = add_depth_noise(depth, mask, rng, sigma=0.002, outlier_frac=0.01)
    assert (noisy[:10] == 0).all()
    resid = noisy[10:] - 1.0
    wrong = np.abs(resid) > 0.02
    assert wrong.sum() == pytest.approx(100, abs=10)  # 1 % of the 10 000 mask pixels (a few land near 1 m)
    assert wrong[40:140, 50:150].sum() == wrong.sum()  # only inside the mask
    assert resid[~wrong].std() == pytest.approx(0.002, rel=0.05)


def test_scene_truth_and_labels(scene: SyntheticScene) -> None:
    assert set(scene.labels.values()) >= {("box", "top"), ("box", "body"), ("plate", "surface"), ("rod", "")}
    top = scene.truth(ElementSpec("t", "box", "top", ElementKind.SURFACE))
    np.testing.assert_allclose(top[:, 2], 0.08)
    with pytest.raises(ElementError, match="no ground truth"):
        scene.truth(ElementSpec("x", "table", "", ElementKind.POINT))
    with pytest.raises(ElementError, match="no object 'cup'"):
        scene.object("cup")
    views = scene.views(seed=0, noise_mm=0.0, outlier_frac=0.0)
    for v in views:
        assert 0.03 < (v.mask_of("box").mean() + v.mask_of("plate").mean() + v.mask_of("rod").mean()) < 0.08
        assert v.mask_of("rod").sum() > 1000


def test_element_errors_metrics() -> None:
    from code_as_monitor.geometry.synthetic import element_errors

    assert element_errors("point", np.array([[0.0, 0.0, 0.003]]), np.zeros((1, 3)))["position_mm"] == pytest.approx(3.0)
    L = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    e = element_errors("line", L[::-1] + np.array([0.0, 0.002, 0.0]), L)  # reversed order does not matter
    assert e["direction_deg"] == pytest.approx(0.0, abs=1e-6) and e["ends_mm"] == pytest.approx(2.0)
    S = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    tilted = S.copy()
    tilted[:, 2] = S[:, 0] * np.tan(np.deg2rad(2.0))
    e = element_errors("surface", tilted, S)
    assert e["normal_deg"] == pytest.approx(2.0)
