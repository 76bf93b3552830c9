"""Pinhole camera model in the OpenCV convention.

Camera frame: x right, y down, z forward (optical axis). World frame: z up, metres.
``K`` is the 3x3 intrinsic matrix; ``T_world_cam`` (4x4) maps camera-frame points to the world frame:
``p_world = T_world_cam @ [p_cam, 1]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.errors import GeometryError

_RIGID_TOL = 1e-4


def validate_intrinsics(K: np.ndarray) -> np.ndarray:
    """Return ``K`` as float64 (3, 3); raise GeometryError if it is not 3x3 or not invertible."""
    K = np.asarray(K, dtype=np.float64)
    if K.shape != (3, 3):
        raise GeometryError(f"intrinsics K must be 3x3, got shape {K.shape}")
    if not np.all(np.isfinite(K)):
        raise GeometryError("intrinsics K contains NaN or inf")
    if abs(np.linalg.det(K)) < 1e-12 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise GeometryError(f"intrinsics K is not invertible (fx={K[0, 0]}, fy={K[1, 1]})")
    return K


def validate_rigid(T: np.ndarray, name: str = "T_world_cam") -> np.ndarray:
    """Return ``T`` as float64 (4, 4); raise GeometryError unless it is a proper rigid transform.

    Rigid means: last row ``[0, 0, 0, 1]``, rotation block orthonormal with determinant +1.
    """
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4):
        raise GeometryError(f"{name} must be 4x4, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise GeometryError(f"{name} contains NaN or inf")
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=_RIGID_TOL):
        raise GeometryError(f"{name} is not rigid: last row is {T[3].tolist()}, expected [0, 0, 0, 1]")
    R = T[:3, :3]
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    if err > _RIGID_TOL or np.linalg.det(R) < 0:
        raise GeometryError(
            f"{name} is not rigid: rotation block deviates from orthonormal by {err:.2e} "
            f"(det={np.linalg.det(R):.4f})"
        )
    return T


@dataclass(frozen=True)
class CameraModel:
    """A calibrated pinhole camera.

    Attributes:
        name: view name ("front", "top", "wrist", ...).
        width, height: image size in pixels.
        K: (3, 3) intrinsics, pixels.
        T_world_cam: (4, 4) camera-to-world rigid transform, metres, OpenCV camera axes.
    """

    name: str
    width: int
    height: int
    K: np.ndarray
    T_world_cam: np.ndarray

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise GeometryError(f"camera {self.name!r}: size must be positive, got {self.width}x{self.height}")
        object.__setattr__(self, "K", validate_intrinsics(self.K))
        object.__setattr__(self, "T_world_cam", validate_rigid(self.T_world_cam))

    @property
    def T_cam_world(self) -> np.ndarray:
        """(4, 4) world-to-camera transform."""
        R = self.T_world_cam[:3, :3]
        t = self.T_world_cam[:3, 3]
        out = np.eye(4)
        out[:3, :3] = R.T
        out[:3, 3] = -R.T @ t
        return out

    @property
    def position(self) -> np.ndarray:
        """(3,) camera centre in the world frame, metres."""
        return self.T_world_cam[:3, 3].copy()

    def project(self, points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project world points to pixels.

        Args:
            points_world: (N, 3) world frame, metres.
        Returns:
            uv: (N, 2) pixel coordinates (u right, v down), float64.
            z: (N,) depth along the optical axis in metres (<= 0 means behind the camera).
        """
        P = np.asarray(points_world, dtype=np.float64).reshape(-1, 3)
        Tcw = self.T_cam_world
        pc = P @ Tcw[:3, :3].T + Tcw[:3, 3]
        z = pc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = (pc[:, :2] / z[:, None]) * np.array([self.K[0, 0], self.K[1, 1]]) + self.K[:2, 2]
        return uv, z

    @classmethod
    def look_at(
        cls,
        name: str,
        eye: np.ndarray,
        target: np.ndarray,
        width: int,
        height: int,
        fov_y_deg: float,
        up: np.ndarray | None = None,
    ) -> CameraModel:
        """A camera at ``eye`` looking at ``target`` (world, metres) with vertical field of view ``fov_y_deg``."""
        eye = np.asarray(eye, dtype=np.float64)
        target = np.asarray(target, dtype=np.float64)
        up = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=np.float64)
        z = target - eye
        if np.linalg.norm(z) < 1e-9:
            raise GeometryError("look_at: eye and target coincide")
        z = z / np.linalg.norm(z)
        x = np.cross(z, up)
        if np.linalg.norm(x) < 1e-6:  # looking straight along `up`: pick any perpendicular
            x = np.cross(z, np.array([0.0, 1.0, 0.0]))
        x = x / np.linalg.norm(x)
        y = np.cross(z, x)
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, eye
        f = 0.5 * height / np.tan(np.deg2rad(fov_y_deg) / 2.0)
        K = np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0.0, 0.0, 1.0]])
        return cls(name=name, width=width, height=height, K=K, T_world_cam=T)

    def to_dict(self) -> dict:
        """JSON-serialisable form."""
        return {
            "name": self.name,
            "width": self.width,
            "height": self.height,
            "K": self.K.tolist(),
            "T_world_cam": self.T_world_cam.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict) -> CameraModel:
        return cls(d["name"], int(d["width"]), int(d["height"]), np.array(d["K"]), np.array(d["T_world_cam"]))
