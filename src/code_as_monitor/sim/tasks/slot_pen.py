"""``slot-pen`` (point level, the paper's OmniGibson "Slot Pen"): put the pen into the pen holder.

Description: a ``pen`` (parts ``body`` and ``tip``; 14 cm, its axis the local +x from body to tip)
lies on the table; a ``pen_holder`` (a square tube with a 5 x 5 cm opening, 8 cm tall; parts ``body``
and ``rim``) stands nearby. Parallel-jaw gripper. Plan: ``grasp`` the pen by its body, ``reorient``
it tip-down, ``insert`` it into the holder.

Randomisation: pen centre x [0.40, 0.52], y [0.06, 0.18] m, heading uniform; holder x [0.42, 0.52],
y [-0.18, -0.08] m, yaw uniform in [0, 90) degrees.

Success: the pen is in the holder: nothing held, the pen tip's centre inside the opening (in the
holder frame, within the inner half-size 2.5 cm on both axes) and at least 2 cm below the rim's top.

Disturbances (config ``disturbance``):
``none``; ``a`` / ``grasp_shift``: while the gripper descends to grasp (grasp point within 5 cm of the
pen body), the pen is slid 6-9 cm and turned 20-60 degrees, so the fingers close on nothing;
``b`` / ``drop``: in transport (the pen upright in the gripper, 3 cm closer to the holder than when
it became upright) the gripper loses the pen; ``c`` / ``holder_shift``: during insertion (pen tip
within 1.5 cm horizontally of the opening centre and less than 5 cm above the rim) the holder is slid
7-9 cm away from the robot's side.
Expected failure signals: (a) the pen is not between the fingers after the grasp and it moved while
the gripper approached; (b) the pen body is no longer at the grasp point; (c) the pen tip is low but
no longer above the opening.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult
from code_as_monitor.sim.triggered import Triggered, drop_held, slide

PEN_TIP_OFFSET = 0.07  # tip link centre along the pen's +x axis, metres (assets/pen.urdf)
HOLDER_INNER_HALF = 0.025  # metres (assets/pen_holder.urdf)
HOLDER_FLOOR = 0.006  # floor plate thickness, metres
RIM_TOP = 0.08  # holder height, metres
DISTURBANCES = {"none": "none", "a": "grasp_shift", "b": "drop", "c": "holder_shift",
                "grasp_shift": "grasp_shift", "drop": "drop", "holder_shift": "holder_shift"}


def pen_in_holder(tip: np.ndarray, holder_pose: np.ndarray, held: bool, depth: float = 0.02) -> tuple[bool, str]:
    """Is the pen in the holder? ``tip`` (3,) the pen tip link centre, ``holder_pose`` (4, 4) the
    holder's base pose (bottom centre), ``held``: the gripper still holds the pen."""
    local = holder_pose[:3, :3].T @ (np.asarray(tip, float) - holder_pose[:3, 3])
    if held:
        return False, "the pen is still held"
    off = float(np.max(np.abs(local[:2])))
    if off > HOLDER_INNER_HALF:
        return False, f"the pen tip is {off * 100:.1f} cm off the opening's centre (outside the opening)"
    if local[2] > RIM_TOP - depth:
        return False, f"the pen tip is {local[2] * 100:.1f} cm above the holder's floor: not inserted"
    return True, "the pen is in the holder"


@TaskConfig.register("slot-pen")
@dataclass
class SlotPenConfig(TaskConfig):
    """``disturbance``: none, a (grasp_shift), b (drop) or c (holder_shift)."""

    time_limit: float = 60.0
    disturbance: str = "none"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.disturbance not in DISTURBANCES:
            raise ConfigError(f"slot-pen.disturbance must be one of {', '.join(DISTURBANCES)}; "
                              f"got {self.disturbance!r}")


class SlotPen(Task):
    ee_kind = "gripper"
    instruction = "put the pen into the pen holder"
    holder_floor = HOLDER_FLOOR

    def __init__(self, config: SlotPenConfig) -> None:
        super().__init__(config)
        self.config: SlotPenConfig = config

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        pen = pb.loadURDF(str(ASSETS / "pen.urdf"), [0.5, 0.1, 0.006], physicsClientId=c)
        holder = pb.loadURDF(str(ASSETS / "pen_holder.urdf"), [0.5, -0.15, 0.0], physicsClientId=c)
        for b in (pen, holder):
            for link in (-1, 0):
                pb.changeDynamics(b, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        pb.changeDynamics(pen, -1, rollingFriction=0.001, spinningFriction=0.001, physicsClientId=c)
        world.add_object("pen", [pen], parts={"body": (pen, -1), "tip": (pen, 0)}, graspable=True)
        world.add_object("pen_holder", [holder], parts={"body": (holder, -1), "rim": (holder, 0)})

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        pen_xy = [rng.uniform(0.40, 0.52), rng.uniform(0.06, 0.18)]
        heading = rng.uniform(-np.pi, np.pi)
        holder_xy = [rng.uniform(0.42, 0.52), rng.uniform(-0.18, -0.08)]
        pb.resetBasePositionAndOrientation(world.body_of("pen"), [*pen_xy, 0.006],
                                           pb.getQuaternionFromEuler([0, 0, heading]), physicsClientId=c)
        pb.resetBasePositionAndOrientation(world.body_of("pen_holder"), [*holder_xy, 0.0],
                                           pb.getQuaternionFromEuler([0, 0, rng.uniform(0, np.pi / 2)]),
                                           physicsClientId=c)

    # --- interface used by the gripper skills ------------------------------------------------------
    def lowest_point(self, world: Any, obj: str) -> np.ndarray:
        """(3,) the pen's tip end (the end that goes into the holder first)."""
        T = world.pose(obj)
        return T[:3, 3] + T[:3, 0] * (PEN_TIP_OFFSET + 0.015)

    def evaluate(self, world: Any) -> TaskResult:
        tip = world.position("pen/tip")
        holder = world.pose("pen_holder")
        held = world.robot.ee.holding == world.body_of("pen")
        ok, reason = pen_in_holder(tip, holder, held)
        info = {"t": world.t, "tip": tip.tolist(), "holder": holder[:3, 3].tolist()}
        if ok and world.t > self.config.time_limit + 1e-9:
            ok, reason = False, f"inserted after the time limit ({world.t:.1f} s)"
        return TaskResult(ok, reason, info)

    def placed(self, world: Any, obj: str, target: str) -> tuple[bool, str] | None:
        """The pen let go into the holder is in it (the success test, nothing held)."""
        if obj != "pen" or target != "pen_holder":
            return None
        return pen_in_holder(world.position("pen/tip"), world.pose("pen_holder"), held=False)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": "pen", "part": "body"}),
            Action("reorient", {"obj": "pen", "axis": "vertical"}),
            Action("insert", {"obj": "pen", "target": "pen_holder"}),
        ]

    # --- disturbances --------------------------------------------------------------------------------
    def disturbances(self, seed: int = 0) -> list[Any]:
        kind = DISTURBANCES[self.config.disturbance]
        if kind == "grasp_shift":
            return [Triggered(kind, _gripper_near("pen"), slide("pen", (0.06, 0.09), (0.35, 1.0)), [seed, 11])]
        if kind == "drop":
            return [Triggered(kind, _TransportCheck("pen", "pen_holder"), drop_held(), [seed, 12])]
        if kind == "holder_shift":
            return [Triggered(kind, _inserting(self), slide("pen_holder", (0.07, 0.09), direction=_away_from_base),
                              [seed, 13])]
        return []


def _gripper_near(obj: str, dist: float = 0.05) -> Any:
    """Condition: the gripper is open/empty and its grasp point within ``dist`` of ``obj``'s centre."""

    def when(world: Any) -> bool:
        ee = world.robot.ee
        return ee.holding is None and float(np.linalg.norm(world.robot.tip() - world.position(obj))) < dist

    return when


class _TransportCheck:
    """Condition: ``obj`` is held upright and has come 3 cm closer to ``target`` than when it became upright."""

    def __init__(self, obj: str, target: str) -> None:
        self.obj, self.target = obj, target
        self.d0: float | None = None

    def __call__(self, world: Any) -> bool:
        if world.robot.ee.holding != world.body_of(self.obj):
            return False
        if abs(world.pose(self.obj)[2, 0]) < np.cos(np.radians(30)):
            return False
        d = float(np.linalg.norm(world.position(self.obj)[:2] - world.position(self.target)[:2]))
        if self.d0 is None:
            self.d0 = d
        return d < self.d0 - 0.03


def _inserting(task: SlotPen) -> Any:
    def when(world: Any) -> bool:
        if world.robot.ee.holding != world.body_of("pen"):
            return False
        end = task.lowest_point(world, "pen")
        holder = world.position("pen_holder")
        return (float(np.linalg.norm(end[:2] - holder[:2])) < 0.015
                and end[2] - (holder[2] + RIM_TOP) < 0.05)

    return when


def _away_from_base(world: Any) -> np.ndarray:
    """Unit (2,) direction: the holder slides sideways, away from the robot's side (towards -y or +x)."""
    p = world.position("pen_holder")[:2]
    u = np.array([0.4, -1.0]) if p[1] < 0 else np.array([0.4, 1.0])
    return u / np.linalg.norm(u)


SlotPenConfig.task_class = SlotPen
