"""CameraModel: validation of K and T_world_cam, projection, look_at, serialisation."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.camera import CameraModel, validate_intrinsics, validate_rigid
from code_as_monitor.core.errors import CamError, GeometryError

K = np.array([[500.0, 0.0, 319.5], [0.0, 500.0, 239.5], [0.0, 0.0, 1.0]])


def test_valid_camera_and_round_trip() -> None:
    cam = CameraModel("front", 640, 480, K, np.eye(4))
    assert cam.K.dtype == np.float64
    np.testing.assert_allclose(cam.T_cam_world, np.eye(4))
    back = CameraModel.from_dict(cam.to_dict())
    assert back.name == "front" and (back.width, back.height) == (640, 480)
    np.testing.assert_allclose(back.K, K)


@pytest.mark.parametrize(
    ("bad_K", "message"),
    [
        (np.eye(4), "must be 3x3"),
        (np.zeros((3, 3)), "not invertible"),
        (np.array([[500.0, 0, 1], [0, -500.0, 1], [0, 0, 1]]), "not invertible"),  # negative fy
        (np.array([[np.nan, 0, 1], [0, 500.0, 1], [0, 0, 1]]), "NaN or inf"),
    ],
)
def test_bad_intrinsics_are_named(bad_K: np.ndarray, message: str) -> None:
    with pytest.raises(GeometryError, match=message):
        CameraModel("c", 640, 480, bad_K, np.eye(4))
    with pytest.raises(GeometryError):
        validate_intrinsics(bad_K)


@pytest.mark.parametrize(
    ("T", "message"),
    [
        (np.diag([2.0, 1.0, 1.0, 1.0]), "not rigid: rotation block"),  # scaled
        (np.diag([1.0, 1.0, -1.0, 1.0]), "not rigid: rotation block"),  # reflection (det -1)
        (np.vstack([np.eye(4)[:3], [0.0, 0.0, 1.0, 1.0]]), "last row"),
        (np.eye(3), "must be 4x4"),
        (np.full((4, 4), np.inf), "NaN or inf"),
    ],
)
def test_non_rigid_pose_is_rejected(T: np.ndarray, message: str) -> None:
    with pytest.raises(GeometryError, match=message):
        CameraModel("c", 640, 480, K, T)
    with pytest.raises(CamError):  # every library error is a CamError (the CLI's one-line exit)
        validate_rigid(T)


def test_bad_size() -> None:
    with pytest.raises(GeometryError, match="size must be positive"):
        CameraModel("c", 0, 480, K, np.eye(4))


def test_look_at_follows_the_opencv_convention() -> None:
    cam = CameraModel.look_at("c", [1.0, 0.0, 1.0], [0.0, 0.0, 0.0], 640, 480, 60.0)
    R = cam.T_world_cam[:3, :3]
    np.testing.assert_allclose(R[:, 2], np.array([-1.0, 0.0, -1.0]) / np.sqrt(2), atol=1e-12)  # z forward
    assert R[2, 1] < 0  # image y (down) points down in the world
    uv, z = cam.project(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.1]]))
    np.testing.assert_allclose(uv[0], [319.5, 239.5], atol=1e-9)  # the target is at the principal point
    assert z[0] == pytest.approx(np.sqrt(2))
    assert uv[1, 1] < uv[0, 1]  # a higher point is higher up in the image
    assert cam.K[1, 1] == pytest.approx(240 / np.tan(np.deg2rad(30)))
    np.testing.assert_allclose(cam.position, [1.0, 0.0, 1.0])
    down = CameraModel.look_at("d", [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 64, 48, 60.0)  # along `up`
    np.testing.assert_allclose(down.T_world_cam[:3, 2], [0, 0, -1], atol=1e-12)
    with pytest.raises(GeometryError, match="coincide"):
        CameraModel.look_at("x", [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 64, 48, 60.0)
