"""Simulated RGB-D cameras: render RGB, metric depth and an object+link segmentation image.

Each camera is defined by an OpenCV-convention :class:`~code_as_monitor.core.CameraModel`
(x right, y down, z forward; ``T_world_cam`` camera -> world). The PyBullet view matrix is derived
from that same model, and the model's principal point is moved by where the renderer samples its pixels
(:data:`PIXEL_SHIFT`), so the exported model is the one the images were rendered with: a point the model
projects to pixel ``(u, v)`` is the one the image shows at ``(u, v)``.

A camera is fixed in the world (``CameraSpec.mount == "world"``) or mounted on the robot's hand
(``"wrist"``): then its ``eye``/``target``/``up`` are in the hand's grasp frame (z the approach
direction, x the jaws' closing axis) and its extrinsics are recomputed from the robot's forward
kinematics before every frame, as a real wrist camera's calibration is composed with the arm's state.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ConfigError, SimError
from code_as_monitor.core.observation import View
from code_as_monitor.sim.backdrop import Backdrop, compose, for_client, raw_images

# OpenCV camera axes -> OpenGL camera axes (x right, y up, z backward).
_CV_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])

RENDERERS = ("tiny", "egl")

PIXEL_SHIFT: dict[str, tuple[float, float]] = {"tiny": (0.5, -0.5), "egl": (0.0, 0.0)}
"""Pixels added to the principal point ``(cx, cy)`` of :meth:`CameraSpec.model` per renderer. PyBullet's
TinyRenderer shows the scene half a pixel right of and above where a camera with ``cx = (W - 1) / 2``,
``cy = (H - 1) / 2`` (pixel centres at integer coordinates) projects it: fitting the projected silhouettes of
blocks of known pose to their rendered masks gives exactly (+0.5, -0.5) with no pixel left over, at 640x480,
320x240, 321x241 and 200x150 and fields of view of 40-70 degrees (``tests/sim/test_camera_pixel_grid.py`` checks
three other cameras to 2 pixels).
Without it every lifted point lay up to half a pixel sideways (about 2 mm at 1 m in a 320x240 view), in a
different direction per view, and the faces of a block seen from the front view read 1-2 mm off its true
faces. The hardware renderer (EGL) was not available to measure (no GL here): no shift is assumed for it."""
MOUNTS = ("world", "wrist")

Images = tuple[np.ndarray, np.ndarray, np.ndarray]
"""One rendered frame of a view: rgb (H, W, 3) uint8, depth (H, W) float32 metres, seg (H, W) int32."""


@dataclass
class CameraSpec:
    """One camera. Positions in metres, in the world frame (``mount="world"``) or in the robot hand's grasp
    frame (``mount="wrist"``); ``fov_y_deg`` vertical field of view in degrees; ``up`` the direction that
    points up in the image (None: world z, or +x when looking straight down)."""

    name: str
    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    width: int = 320
    height: int = 240
    fov_y_deg: float = 50.0
    near: float = 0.05
    far: float = 3.0
    mount: str = "world"
    up: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.mount not in MOUNTS:
            raise ConfigError(f"camera {self.name!r}: mount must be one of {', '.join(MOUNTS)}, got {self.mount!r}")
        if self.width <= 0 or self.height <= 0:
            raise ConfigError(f"camera {self.name!r}: size must be positive, got {self.width}x{self.height}")
        if not 0 < self.near < self.far:
            raise ConfigError(f"camera {self.name!r}: need 0 < near < far, got near={self.near} far={self.far}")
        if not 1.0 <= self.fov_y_deg <= 170.0:
            raise ConfigError(f"camera {self.name!r}: fov_y_deg must be in [1, 170], got {self.fov_y_deg}")

    def model(self) -> CameraModel:
        """The camera model; for a mounted camera its ``T_world_cam`` is camera -> mount frame."""
        up = np.array([0.0, 0.0, 1.0]) if self.up is None else np.asarray(self.up, float)
        d = np.asarray(self.target, float) - np.asarray(self.eye, float)
        if self.up is None and np.linalg.norm(np.cross(d, up)) < 1e-6 * max(np.linalg.norm(d), 1e-9):
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


def rlbench_cameras(width: int = 320, height: int = 240) -> list[CameraSpec]:
    """RLBench's four views: ``front`` (across the table, facing the robot, as :func:`default_cameras`),
    ``left_shoulder`` and ``right_shoulder`` (above and behind the robot's base, looking over its shoulders
    at the workspace) and ``wrist`` (on the hand, 5.5 cm beside the closing axis at the palm, looking down the
    approach direction past the fingers; its pose follows the arm every frame)."""
    return [
        CameraSpec("front", eye=(1.15, 0.0, 0.65), target=(0.45, 0.0, 0.0), width=width, height=height,
                   fov_y_deg=50.0),
        CameraSpec("left_shoulder", eye=(0.15, 0.62, 0.95), target=(0.50, -0.02, 0.0), width=width,
                   height=height, fov_y_deg=45.0),
        CameraSpec("right_shoulder", eye=(0.15, -0.62, 0.95), target=(0.50, 0.02, 0.0), width=width,
                   height=height, fov_y_deg=45.0),
        CameraSpec("wrist", eye=(0.0, 0.055, 0.0), target=(0.0, 0.0, 0.20), width=width, height=height,
                   fov_y_deg=60.0, near=0.01, far=2.0, mount="wrist", up=(1.0, 0.0, 0.0)),
    ]


def shoulder_cameras(width: int = 320, height: int = 240) -> list[CameraSpec]:
    """Two views over the robot's shoulders, at y = +-0.5 m, 0.75 m up, looking at the table centre line: the element
    benchmark's views that no test's closed loop uses (``benchmarks/element_accuracy.py``)."""
    return [
        CameraSpec("shoulder_left", eye=(0.3, 0.5, 0.75), target=(0.3, 0.0, 0.0), width=width, height=height,
                   fov_y_deg=60.0),
        CameraSpec("shoulder_right", eye=(0.3, -0.5, 0.75), target=(0.3, 0.0, 0.0), width=width, height=height,
                   fov_y_deg=60.0),
    ]


def front_camera(width: int = 320, height: int = 240) -> list[CameraSpec]:
    """The front view alone (:func:`default_cameras`' first)."""
    return default_cameras(width, height)[:1]


CAMERA_SETS: dict[str, Callable[[int, int], list[CameraSpec]] | None] = {
    "task": None,
    "front-top": default_cameras,
    "front": front_camera,
    "shoulders": shoulder_cameras,
    "rlbench": rlbench_cameras,
}
"""Named camera sets for a simulated episode (``cam run --cameras``): ``task`` the task's own (front and top, or
RLBench's four for the RLBench-style tasks), else one set for every task."""


def camera_set(name: str, width: int, height: int) -> list[CameraSpec] | None:
    """The cameras of set ``name`` (:data:`CAMERA_SETS`) at ``width`` x ``height``; None for ``task`` (the task's own).
    A name ending in ``.json`` is a camera file of the user's own views (:mod:`.camera_file`; ``width`` x ``height``
    for the cameras that give no size). ConfigError names an unknown set or a bad file."""
    from code_as_monitor.sim.camera_file import is_camera_file, load_camera_file

    if is_camera_file(name):
        return load_camera_file(name, width, height, CameraSpec)
    if name not in CAMERA_SETS:
        raise ConfigError(f"unknown camera set {name!r}; choose one of: {', '.join(CAMERA_SETS)}, "
                          f"or a camera file (.json)")
    make = CAMERA_SETS[name]
    return None if make is None else make(width, height)


def check_views_kept(set_name: str, keep: list[str] | None, who: str) -> None:
    """ConfigError when ``who`` (an ablation, a benchmark method) keeps views ``keep`` that camera set ``set_name``
    (:data:`CAMERA_SETS`) does not have; nothing to check for ``task`` (each task has the views the ablations keep)
    or when nothing is kept. An unknown set is a ConfigError too."""
    specs = camera_set(set_name, 320, 240)  # names only: the size does not matter
    if specs is None or not keep:
        return
    names = [c.name for c in specs]
    if not set(keep) <= set(names):
        raise ConfigError(f"{who} keeps the view(s) {', '.join(keep)}, which camera set {set_name!r} does not have "
                          f"({', '.join(names)})")


def shifted_principal_point(camera: CameraModel, du: float, dv: float) -> CameraModel:
    """``camera`` with ``du`` / ``dv`` pixels added to its principal point ``(cx, cy)`` (everything else kept)."""
    K = camera.K.copy()
    K[0, 2] += du
    K[1, 2] += dv
    return CameraModel(camera.name, camera.width, camera.height, K, camera.T_world_cam)


MountPose = Callable[[], np.ndarray]
"""Returns the (4, 4) world pose of the frame a mounted camera is fixed to (the hand's grasp frame)."""


@dataclass
class SimCamera:
    """A camera bound to a PyBullet client. ``render`` returns a core :class:`View`.

    ``mount_pose``: for a camera on the robot (``spec.mount != "world"``), the function giving its mount
    frame's current world pose; ``camera`` (the model a View carries) is then recomputed before every frame.
    """

    spec: CameraSpec
    client: int
    renderer: str = "tiny"
    mount_pose: MountPose | None = None
    backdrop: Backdrop | None = None
    """The table rendered apart and composed under each TinyRenderer frame (:mod:`.backdrop`); by default the one
    registered for ``client`` by its world (none: the client's own render is the frame, the table drawn in it)."""
    camera: CameraModel = field(init=False)
    _view: list[float] = field(init=False)
    _proj: list[float] = field(init=False)
    _T_mount_cam: np.ndarray | None = field(init=False, default=None)
    frames: int = field(init=False, default=0)  # images rendered so far

    def __post_init__(self) -> None:
        import pybullet as pb

        if (self.spec.mount != "world") != (self.mount_pose is not None):
            raise ConfigError(f"camera {self.spec.name!r}: a {self.spec.mount}-mounted camera "
                              f"{'needs' if self.mount_pose is None else 'takes no'} mount_pose")
        if self.renderer not in RENDERERS:
            raise ConfigError(f"unknown renderer {self.renderer!r}; choose one of: {', '.join(RENDERERS)}")
        if self.backdrop is None:
            self.backdrop = for_client(self.client)
        self.camera = shifted_principal_point(self.spec.model(), *PIXEL_SHIFT[self.renderer])
        if self.mount_pose is not None:
            self._T_mount_cam = self.camera.T_world_cam.copy()
            self.follow_mount()
        self._set_view()
        s = self.spec
        self._proj = list(pb.computeProjectionMatrixFOV(s.fov_y_deg, s.width / s.height, s.near, s.far,
                                                        physicsClientId=self.client))

    def _set_view(self) -> None:
        T_gl = _CV_TO_GL @ self.camera.T_cam_world
        self._view = T_gl.flatten(order="F").tolist()  # column-major, as OpenGL wants

    def follow_mount(self) -> None:
        """Recompute a mounted camera's extrinsics from its mount's current pose (no-op for a world camera)."""
        if self.mount_pose is None or self._T_mount_cam is None:
            return
        T = np.asarray(self.mount_pose(), float) @ self._T_mount_cam
        U, _, Vt = np.linalg.svd(T[:3, :3])  # re-orthonormalise the float32 quaternion's rotation
        T[:3, :3] = U @ Vt
        c = self.camera
        self.camera = CameraModel(c.name, c.width, c.height, c.K, T)
        self._set_view()

    def render(self, seg_labels: dict[int, tuple[str, str]]) -> View:
        """Render one frame now.

        Returns a View with rgb (H, W, 3) uint8, depth (H, W) float32 metres along the optical axis
        (0 = no reading, i.e. the far plane), seg (H, W) int32 with PyBullet's
        ``objectUniqueId + ((linkIndex + 1) << 24)`` ids (-1 background) and ``seg_labels``.
        """
        self.follow_mount()
        rgb, depth, seg = self.images(self._view)
        return View(rgb=rgb, depth=depth, camera=self.camera, seg=seg, seg_labels=dict(seg_labels))

    def defer(self, seg_labels: dict[int, tuple[str, str]], clock: Callable[[], int],
              fetch: Callable[[list[float]], Images] | None = None) -> DeferredView:
        """A View of the scene as it is now whose images are rendered when first read (see
        :class:`DeferredView`); ``clock()`` is the world's tick counter at the time of reading;
        ``fetch(view_matrix)`` gives the images (default :meth:`images`; a world passes its cache)."""
        get = fetch or self.images
        self.follow_mount()  # a mounted camera's pose is the one of this instant, fixed here
        view = self._view
        return DeferredView(self.camera, dict(seg_labels), lambda: get(view), clock)

    def images(self, view_matrix: list[float]) -> Images:
        """One ``getCameraImage`` call from ``view_matrix`` (column-major OpenGL): rgb (H, W, 3) uint8,
        depth (H, W) float32 metres (0 = no reading), seg (H, W) int32 (see :meth:`render`)."""
        import pybullet as pb

        s = self.spec
        if self.renderer == "egl":
            _, _, rgba, zbuf, seg = pb.getCameraImage(
                s.width, s.height, viewMatrix=view_matrix, projectionMatrix=self._proj,
                renderer=pb.ER_BULLET_HARDWARE_OPENGL, flags=pb.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX,
                shadow=0, physicsClientId=self.client,
            )
            raw = (np.reshape(np.asarray(rgba, dtype=np.uint8), (s.height, s.width, 4)),
                   np.reshape(np.asarray(zbuf, dtype=np.float64), (s.height, s.width)),
                   np.reshape(np.asarray(seg, dtype=np.int64), (s.height, s.width)).astype(np.int32))
        else:
            raw = raw_images(self.client, s.width, s.height, view_matrix, self._proj)
            if self.backdrop is not None:
                raw = compose(raw, self.backdrop.images(s.width, s.height, view_matrix, self._proj))
        self.frames += 1
        rgba_img, z, seg_img = raw
        rgb = np.ascontiguousarray(rgba_img[:, :, :3])
        depth = (s.far * s.near / (s.far - (s.far - s.near) * z)).astype(np.float32)
        depth[z >= 1.0 - 1e-7] = 0.0
        return rgb, depth, seg_img


class DeferredView(View):
    """A :class:`View` whose images are rendered the first time ``rgb``, ``depth`` or ``seg`` is read.

    A consumer that reads only ``camera`` (a pose-based tracker, a visibility count) costs no render; one
    that reads the images gets exactly what an eager render at creation time would have given, because
    the camera pose is fixed at creation and the read must happen before the world moves on: reading the
    images after the world's tick counter (``clock()``) changed raises :class:`SimError` (the frame would
    show a later instant). A world rewound to the same tick (counterfactual rollouts restore the physics
    state) still renders. Pickling or copying renders it and gives a plain :class:`View`.
    """

    def __init__(self, camera: CameraModel, seg_labels: dict[int, tuple[str, str]], fetch: Callable[[], Images],
                 clock: Callable[[], int]) -> None:
        self.camera = camera
        self.seg_labels = seg_labels
        self._fetch = fetch
        self._clock = clock
        self._tick = clock()
        self._images: Images | None = None

    @property
    def rendered(self) -> bool:
        """True once the images exist."""
        return self._images is not None

    def _get(self) -> Images:
        if self._images is None:
            now = self._clock()
            if now != self._tick:
                raise SimError(
                    f"view {self.camera.name!r} of tick {self._tick} read at tick {now}: its images were never "
                    "rendered and the world has moved on; read them before stepping (or observe(eager=True))")
            self._images = self._fetch()
        return self._images

    @property  # type: ignore[override]
    def rgb(self) -> np.ndarray:
        return self._get()[0]

    @property  # type: ignore[override]
    def depth(self) -> np.ndarray:
        return self._get()[1]

    @property  # type: ignore[override]
    def seg(self) -> np.ndarray:
        return self._get()[2]

    def materialize(self) -> View:
        """A plain View with the images rendered."""
        rgb, depth, seg = self._get()
        return View(rgb=rgb, depth=depth, camera=self.camera, seg=seg, seg_labels=self.seg_labels)

    def __reduce__(self) -> tuple:
        v = self.materialize()
        return (View, (v.rgb, v.depth, v.camera, v.seg, v.seg_labels))

    def __repr__(self) -> str:
        return f"DeferredView({self.camera.name!r}, tick={self._tick}, rendered={self.rendered})"


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
