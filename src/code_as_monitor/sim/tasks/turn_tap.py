"""``turn-tap`` (rotational manipulation, RLBench's "turn tap"): turn the left (or right) tap's handle open.

Description: a ``tap`` (``assets/tap.urdf``, a fixed-base articulated body) with parts ``body`` (the deck and
spout), ``left_handle`` (red) and ``right_handle`` (blue), each a lever on its own real revolute joint about the
vertical, closed with the lever pointing towards the robot. Turning a handle outwards by ``TURN_ANGLE`` (90
degrees, a quarter-turn; the left one clockwise seen from above, the right one anticlockwise) opens it; a friction
motor keeps a lever where it is left. Config ``angle``: how far to turn it (degrees, ``MIN_ANGLE`` to
``TURN_ANGLE``; "turn the left tap 45 degrees" sets it). Parallel-jaw gripper; RLBench's four cameras. Plan:
``grasp`` the handle's lever (jaws across the bar), ``turn`` it about its hinge (the grasp point follows the arc),
let go, park.

Randomisation: the tap 0.45-0.55 m from the base at a bearing within +-20 degrees, its front (+x) facing the
base within +-15 degrees. Config ``side``: which handle the instruction names (RLBench's two variations).

Success: the named handle is turned open by ``angle`` give or take ``TURN_TOL`` (15 degrees: at least 75 for the
quarter-turn; its travel, 100 degrees, ends before 105), the other one stays within ``OTHER_MAX`` (20 degrees) of
closed, and the gripper has let go, within the time limit.

Disturbances: none (the RLBench protocol injects none); the policy's own mistakes are the failures. Action
noise (``NOISE``): the grasp point, the turn's angle, and now and then the other handle taken for the named
one (``wrong_target``). Ground truth: ``policy_failure`` with ``what`` ``grasp_missed`` (the jaws closed on
nothing of the tap), ``wrong_target`` (they closed on the other handle) or ``turn_short`` (let go with the named
handle turned less than ``angle - TURN_TOL``).
Expected failure signals: the named handle's lever is not between the jaws after the grasp; the lever's
direction has not turned by the angle asked for after the turn; the other handle's lever moved.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.tasks.base import TaskConfig, TaskResult
from code_as_monitor.sim.tasks.rlbench_base import RLBenchConfig, RLBenchTask

OBJ = "tap"
TURN_ANGLE = 90.0  # degrees the plan asks for by default (a quarter-turn), and the most it may ask for
MIN_ANGLE = 30.0  # degrees: the least turn a task may ask for (below it the tolerance reaches the closed lever)
TURN_TOL = 15.0  # degrees: success within this of the angle asked for
OTHER_MAX = np.radians(20.0)  # ... and the other within this of closed
LEVER_CENTRE = np.array([0.042, 0.0, 0.023])  # the lever bar's centre in its handle's frame (the hinge), metres
VALVE_FRICTION = 0.05  # N m, a handle's turning friction (a velocity motor with target 0; at 0.3 the soft grasp
# constraint could not drag the lever round in some poses: it stopped at 22 degrees, measured)
SIDES = ("left", "right")


@TaskConfig.register("turn-tap")
@dataclass
class TurnTapConfig(RLBenchConfig):
    """``side``: ``left`` or ``right``, the handle to turn; ``angle``: degrees to turn it open (``MIN_ANGLE`` to
    ``TURN_ANGLE``); ``noise``: scale of the policy's action noise."""

    time_limit: float = 40.0
    side: str = "left"
    angle: float = TURN_ANGLE

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.side not in SIDES:
            raise ConfigError(f"turn-tap.side must be one of {', '.join(SIDES)}; got {self.side!r}")
        if not isinstance(self.angle, (int, float)) or not MIN_ANGLE <= float(self.angle) <= TURN_ANGLE:
            raise ConfigError(f"turn-tap.angle must be {MIN_ANGLE:g} to {TURN_ANGLE:g} degrees; got {self.angle!r}")


def describe_turn(side: str, angle: float) -> str:
    """The instruction for turning the ``side`` tap ``angle`` degrees (the grammar reads it back to the same)."""
    return f"turn the {side} tap" if abs(angle - TURN_ANGLE) < 1e-9 else f"turn the {side} tap {angle:g} degrees"


class TurnTap(RLBenchTask):
    NOISE: ClassVar[dict[str, float]] = {"grasp_xy": 0.006, "grasp_z": 0.003, "grasp_yaw": 0.05, "turn_rel": 0.07,
                                         "wrong_target": 0.02}

    def __init__(self, config: TurnTapConfig) -> None:
        super().__init__(config)
        self.config: TurnTapConfig = config
        self.part = f"{config.side}_handle"
        self.other = f"{'right' if config.side == 'left' else 'left'}_handle"
        self.instruction = describe_turn(config.side, float(config.angle))  # type: ignore[misc]
        self.joints: dict[str, int] = {}

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        body = pb.loadURDF(str(ASSETS / "tap.urdf"), [0.5, 0.0, 0.0], useFixedBase=True, physicsClientId=c)
        links = {pb.getJointInfo(body, j, physicsClientId=c)[12].decode(): j
                 for j in range(pb.getNumJoints(body, physicsClientId=c))}
        self.joints = {p: links[p] for p in ("left_handle", "right_handle")}
        for j in self.joints.values():
            pb.setJointMotorControl2(body, j, pb.VELOCITY_CONTROL, targetVelocity=0.0, force=VALVE_FRICTION,
                                     physicsClientId=c)
        for link in (-1, *links.values()):
            pb.changeDynamics(body, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        world.add_object(OBJ, [body], parts={"body": (body, -1), **{p: (body, j) for p, j in self.joints.items()}},
                         graspable=True)

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        r, bearing = rng.uniform(0.45, 0.55), rng.uniform(-np.radians(20), np.radians(20))
        yaw = bearing + np.pi + rng.uniform(-np.radians(15), np.radians(15))
        body = world.body_of(OBJ)
        pb.resetBasePositionAndOrientation(body, [r * np.cos(bearing), r * np.sin(bearing), 0.0],
                                           pb.getQuaternionFromEuler([0, 0, yaw]), physicsClientId=c)
        for j in self.joints.values():
            pb.resetJointState(body, j, 0.0, 0.0, physicsClientId=c)

    # --- interface used by the skills --------------------------------------------------------------------
    def angle(self, world: Any, part: str) -> float:
        """A handle's joint angle (radians, 0 closed)."""
        import pybullet as pb

        return float(pb.getJointState(world.body_of(OBJ), self.joints[part], physicsClientId=world.client)[0])

    @staticmethod
    def turn_sign(part: str) -> float:
        """+1 when ``part`` opens anticlockwise seen from above (the right handle), -1 clockwise (the left)."""
        return -1.0 if part == "left_handle" else 1.0

    def confusable(self, obj: str, part: str) -> str:
        """The handle that can be taken for ``part`` (the other one), "" for anything else."""
        return {"left_handle": "right_handle", "right_handle": "left_handle"}.get(part, "") if obj == OBJ else ""

    def grasp_centre(self, world: Any, obj: str, part: str = "") -> np.ndarray:
        """(3,) world grasp point: a handle's lever bar's centre (else the part's bounding-box centre)."""
        if obj == OBJ and part in self.joints:
            T = world.pose(f"{OBJ}/{part}")
            return T[:3, :3] @ LEVER_CENTRE + T[:3, 3]
        import pybullet as pb

        b, link = world.objects[obj].parts.get(part, (world.body_of(obj), -1))
        lo, hi = pb.getAABB(b, link, physicsClientId=world.client)
        return (np.asarray(lo) + np.asarray(hi)) / 2

    def grasp_axis(self, world: Any, obj: str, part: str = "") -> np.ndarray:
        """(3,) the direction the jaws close across: a handle's lever (its local x)."""
        name = f"{OBJ}/{part}" if part in self.joints else obj
        return world.pose(name)[:3, 0].copy()

    def grasp_yaw(self, world: Any, obj: str, part: str, current: float) -> float | None:
        """Of the two jaw-symmetric yaws, the one from which the turn stays in the wrist's range (it turns the tool
        by the handle's own opening direction, so it starts on the other side of 'pointing along the lever')."""
        if part not in self.joints:
            return None
        u = self.grasp_axis(world, obj, part)
        base = float(np.arctan2(u[0], -u[1]))  # one of the two; the other is base + pi
        want = -self.turn_sign(part) * np.pi / 2  # start near +90 degrees for a clockwise turn, -90 for the other
        return min((base, base + np.pi, base - np.pi), key=lambda y: abs(y - want))

    # --- ground truth ----------------------------------------------------------------------------------------
    def opened(self, world: Any, part: str) -> float:
        """How far ``part`` is turned in its opening direction, radians."""
        return self.turn_sign(part) * self.angle(world, part)

    def turn_band(self) -> tuple[float, float]:
        """(least, most) radians the named handle may be turned open for success."""
        a = float(self.config.angle)
        return float(np.radians(a - TURN_TOL)), float(np.radians(a + TURN_TOL))

    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        if skill == "turn" and self.opened(world, self.part) < self.turn_band()[0]:
            return "turn_short"
        return super().judge(world, skill, args)

    def evaluate(self, world: Any) -> TaskResult:
        a, o = self.opened(world, self.part), abs(self.angle(world, self.other))
        held = world.robot.ee.holding == world.body_of(OBJ)
        info = {"t": world.t, "opened_deg": float(np.degrees(a)), "other_deg": float(np.degrees(o))}
        least, most = self.turn_band()
        if a < least:
            return TaskResult(False, f"the {self.config.side} tap is turned {np.degrees(a):.0f} degrees "
                                     f"(needs {np.degrees(least):.0f})", info)
        if a > most:
            return TaskResult(False, f"the {self.config.side} tap is turned {np.degrees(a):.0f} degrees, more "
                                     f"than the {float(self.config.angle):g} asked for (at most "
                                     f"{np.degrees(most):.0f})", info)
        if o > OTHER_MAX:
            return TaskResult(False, f"the other tap was turned too ({np.degrees(o):.0f} degrees)", info)
        if held:
            return TaskResult(False, "the tap is turned but still in the gripper", info)
        if world.t > self.config.time_limit + 1e-9:
            return TaskResult(False, f"turned after the time limit ({world.t:.1f} s)", info)
        return TaskResult(True, f"the {self.config.side} tap is turned {np.degrees(a):.0f} degrees", info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": OBJ, "part": self.part}),
            Action("turn", {"obj": OBJ, "part": self.part, "angle": float(self.config.angle)}),
        ]


TurnTapConfig.task_class = TurnTap
