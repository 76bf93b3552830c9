"""Simulated RGB-D cameras: render RGB, metric depth and an object+link segmentation image.

Each camera is defined by an OpenCV-convention :class:`~code_as_monitor.core.CameraModel`
(x right, y down, z forward; ``T_world_cam`` camera -> world). The PyBullet view matrix is derived
from that same model, so the exported model is exactly the one used for rendering.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.observation import View

# OpenCV camera axes -> OpenGL camera axes (x right, y up, z backward).
_CV_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])

RENDERERS = ("tiny", "egl")


@dataclass
class CameraSpec:
    """One camera. Positions in world metres; ``fov_y_deg`` vertical field of view in degrees."""

    name: str
    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    width: int = 320
    height: int = 240
    fov_y_deg: float = 50.0
    near: float = 0.05
    far: float = 3.0

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise ConfigError(f"camera {self.name!r}: size must be positive, got {self.width}x{self.height}")
        if not 0 < self.near < self.far:
            raise ConfigError(f"camera {self.name!r}: need 0 < near < far, got near={self.near} far={self.far}")
        if not 1.0 <= self.fov_y_deg <= 170.0:
            raise ConfigError(f"camera {self.name!r}: fov_y_deg must be in [1, 170], got {self.fov_y_deg}")

    def model(self) -> CameraModel:
        up = np.array([0.0, 0.0, 1.0])
        d = np.asarray(self.target, float) - np.asarray(self.eye, float)
        if np.linalg.norm(np.cross(d, up)) < 1e-6 * max(np.linalg.norm(d), 1e-9):
            up = np.array([1.0, 0.0, 0.0])  # straight down: image "up" points away from the robot (+x)
        return CameraModel.look_at(self.name, np.array(self.eye), np.array(self.target),
                                   self.width, self.height, self.fov_y_deg, up=up)


def default_cameras(width: int = 320, height: int = 240) -> list[CameraSpec]:
    """The paper's two CLIPort views: a third-person front view and a top view of the workspace."""
    return [
        CameraSpec("front", eye=(1.15, 0.0, 0.65), target=(0.45, 0.0, 0.0), width=width, height=height,
                   fov_y_deg=50.0),
        CameraSpec("top", eye=(0.5, 0.0, 1.5), target=(0.5, 0.0, 0.0), width=width, height=height,
                   fov_y_deg=32.0),
    ]


@dataclass
class SimCamera:
    """A camera bound to a PyBullet client. ``render`` returns a core :class:`View`."""

    spec: CameraSpec
    client: int
    renderer: str = "tiny"
    camera: CameraModel = field(init=False)
    _view: list[float] = field(init=False)
    _proj: list[float] = field(init=False)

    def __post_init__(self) -> None:
        import pybullet as pb

        self.camera = self.spec.model()
        T_gl = _CV_TO_GL @ self.camera.T_cam_world
        self._view = T_gl.flatten(order="F").tolist()  # column-major, as OpenGL wants
        s = self.spec
        self._proj = list(pb.computeProjectionMatrixFOV(s.fov_y_deg, s.width / s.height, s.near, s.far,
                                                        physicsClientId=self.client))
        if self.renderer not in RENDERERS:
            raise ConfigError(f"unknown renderer {self.renderer!r}; choose one of: {', '.join(RENDERERS)}")

    def render(self, seg_labels: dict[int, tuple[str, str]]) -> View:
        """Render one frame.

        Returns a View with rgb (H, W, 3) uint8, depth (H, W) float32 metres along the optical axis
        (0 = no reading, i.e. the far plane), seg (H, W) int32 with PyBullet's
        ``objectUniqueId + ((linkIndex + 1) << 24)`` ids (-1 background) and ``seg_labels``.
        """
        import pybullet as pb

        s = self.spec
        flags = pb.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX
        r = pb.ER_BULLET_HARDWARE_OPENGL if self.renderer == "egl" else pb.ER_TINY_RENDERER
        _, _, rgba, zbuf, seg = pb.getCameraImage(
            s.width, s.height, viewMatrix=self._view, projectionMatrix=self._proj, renderer=r, flags=flags,
            shadow=0, physicsClientId=self.client,
        )
        rgb = np.ascontiguousarray(np.reshape(np.asarray(rgba, dtype=np.uint8), (s.height, s.width, 4))[:, :, :3])
        z = np.reshape(np.asarray(zbuf, dtype=np.float64), (s.height, s.width))
        depth = (s.far * s.near / (s.far - (s.far - s.near) * z)).astype(np.float32)
        depth[z >= 1.0 - 1e-7] = 0.0
        seg_img = np.reshape(np.asarray(seg, dtype=np.int64), (s.height, s.width)).astype(np.int32)
        return View(rgb=rgb, depth=depth, camera=self.camera, seg=seg_img, seg_labels=dict(seg_labels))


def load_egl(client: int) -> bool:
    """Try to load PyBullet's EGL renderer plugin on ``client``; True when it loaded."""
    import importlib.util

    import pybullet as pb

    spec = importlib.util.find_spec("eglRenderer")
    try:
        if spec is not None and spec.origin:
            pid = pb.loadPlugin(spec.origin, "_eglRendererPlugin", physicsClientId=client)
        else:
            pid = pb.loadPlugin("eglRendererPlugin", physicsClientId=client)
    except Exception:  # pragma: no cover - platform dependent
        return False
    return pid >= 0


def decode_seg_id(value: int) -> tuple[int, int]:
    """PyBullet seg value -> (body unique id, link index); link -1 is the base."""
    return value & ((1 << 24) - 1), (value >> 24) - 1


def encode_seg_id(body: int, link: int) -> int:
    """(body unique id, link index) -> the seg value PyBullet writes for it."""
    return body + ((link + 1) << 24)
