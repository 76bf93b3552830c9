"""What the agent sees each frame: multi-view RGB-D images, cameras and robot state.

Nothing here knows about the simulator: a real robot fills the same containers.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ObservationError, ShapeMismatchError


@dataclass
class View:
    """One camera's frame.

    Attributes:
        rgb: (H, W, 3) uint8.
        depth: (H, W) float32 metres; 0 or NaN means "no reading".
        camera: the calibrated camera that took it.
        seg: optional (H, W) int32 segmentation id image (simulator ground truth, or a real
            segmenter's output); ids are decoded by ``seg_labels``.
        seg_labels: optional map from a seg id to ``(object name, part name)``; the part name is
            ``""`` for the whole-object id. This is how part-level masks reach the painter without
            the painter importing the simulator.
    """

    rgb: np.ndarray
    depth: np.ndarray
    camera: CameraModel
    seg: np.ndarray | None = None
    seg_labels: dict[int, tuple[str, str]] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.camera, CameraModel):
            raise ObservationError(f"View.camera must be a CameraModel, got {type(self.camera).__name__}")
        for name in ("rgb", "depth") + (("seg",) if self.seg is not None else ()):
            if not isinstance(getattr(self, name), np.ndarray):
                raise ObservationError(f"view {self.camera.name!r}: {name} must be a numpy array, got "
                                       f"{type(getattr(self, name)).__name__}")
        if self.rgb.ndim != 3 or self.rgb.shape[2] != 3:
            raise ShapeMismatchError(f"view {self.camera.name!r}: rgb must be (H, W, 3), got {self.rgb.shape}")
        hw = self.rgb.shape[:2]
        if self.depth.shape != hw:
            raise ShapeMismatchError(
                f"view {self.camera.name!r}: depth shape {self.depth.shape} != rgb shape {hw}"
            )
        if hw != (self.camera.height, self.camera.width):
            raise ShapeMismatchError(
                f"view {self.camera.name!r}: image {hw} does not match camera "
                f"{(self.camera.height, self.camera.width)}"
            )
        if self.seg is not None and self.seg.shape != hw:
            raise ShapeMismatchError(f"view {self.camera.name!r}: seg shape {self.seg.shape} != {hw}")

    def mask_of(self, obj: str, part: str = "") -> np.ndarray:
        """(H, W) bool mask of object ``obj`` (all its parts when ``part`` is empty) or of one part."""
        if self.seg is None or self.seg_labels is None:
            return np.zeros(self.depth.shape, dtype=bool)
        ids = [i for i, (o, p) in self.seg_labels.items() if o == obj and (not part or p == part)]
        return np.isin(self.seg, ids) if ids else np.zeros(self.depth.shape, dtype=bool)


@dataclass
class RobotState:
    """Robot state at one frame.

    Attributes:
        ee_pose: (4, 4) end-effector pose in the world frame (forward kinematics), metres.
        gripper: gripper/suction state: 1.0 closed or suction on, 0.0 open or off.
        ee_kind: "suction", "spatula", "gripper", ...
        ee_points: named end-effector points (3,) in the world frame, e.g. {"tip": ...}; forward
            kinematics gives these directly, so the painter need not segment the end-effector.
        joints: (n,) joint positions, radians (or metres for prismatic joints).
    """

    ee_pose: np.ndarray
    gripper: float = 0.0
    ee_kind: str = "suction"
    ee_points: dict[str, np.ndarray] = field(default_factory=dict)
    joints: np.ndarray | None = None

    @property
    def tip(self) -> np.ndarray:
        """(3,) float64 world metres: the end effector's ``"tip"`` point, else the ``ee_pose`` origin."""
        return np.asarray(self.ee_points.get("tip", self.ee_pose[:3, 3]), dtype=np.float64).reshape(3)


@dataclass
class Observation:
    """Everything the monitor sees at time ``t``.

    Attributes:
        t: seconds, monotonic (sim time in the simulator, a robot clock on hardware).
        views: view name -> :class:`View`.
        robot: the robot's state, or None when there is no robot model.
        objects: names of the objects in the scene (what a scene graph or the task config knows);
            used by the planner to ground the instruction.
        object_poses: ground-truth (4, 4) world poses by object name (part poses as "obj/part").
            Only a simulator fills this (for the `sim` oracle tracker and for evaluation); None on a
            real robot. The monitor never needs it.
    """

    t: float
    views: dict[str, View]
    robot: RobotState | None = None
    objects: list[str] = field(default_factory=list)
    object_poses: dict[str, np.ndarray] | None = None

    @property
    def view_names(self) -> list[str]:
        return list(self.views)

    @property
    def tip(self) -> np.ndarray | None:
        """(3,) world metres: the end effector's tip (:attr:`RobotState.tip`), or None without robot state."""
        return None if self.robot is None else self.robot.tip


def engaged(obs: Observation) -> bool:
    """Whether the end effector holds or may hold something in ``obs``: gripper closed or suction on
    (:attr:`RobotState.gripper` at least 0.5); False without robot state."""
    return obs.robot is not None and float(obs.robot.gripper) >= 0.5


def check_observation(obs: object, where: str = "Monitor.step") -> None:
    """Raise :class:`ObservationError` naming what is wrong unless ``obs`` is an :class:`Observation` with
    a finite time ``t`` and a dict of :class:`View` (the views check their own arrays)."""
    if not isinstance(obs, Observation):
        raise ObservationError(f"{where}: expected an Observation, got {type(obs).__name__}")
    t = obs.t
    if isinstance(t, bool) or not isinstance(t, numbers.Real) or not math.isfinite(t):
        raise ObservationError(f"{where}: observation time t must be a finite number of seconds, got {t!r}")
    if not isinstance(obs.views, dict):
        raise ObservationError(f"{where}: observation at t={t} must have a dict of views, got {obs.views!r}")
    for name, v in obs.views.items():
        if not isinstance(v, View):
            raise ObservationError(f"{where}: view {name!r} at t={t} is a {type(v).__name__}, not a View")
