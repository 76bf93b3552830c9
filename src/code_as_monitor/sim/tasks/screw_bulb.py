"""``screw-bulb`` (rotational manipulation, RLBench's "screw in the light bulb"): screw the bulb into its socket.

Description: a ``lamp`` (``assets/lamp.urdf``, a fixed-base articulated body) with parts ``base`` (a pedestal),
``socket`` (its brass mouth) and ``bulb`` (a red ball on a white neck) sitting loose in the socket, standing
``UNSCREWED`` (1.5 cm) out of its screwed-in position. The bulb hangs from two real joints: a prismatic
``thread_depth`` (how far it stands out) and a continuous revolute ``bulb_turn`` about the vertical; the task
couples them as a right-hand thread of ``THREAD_PITCH`` per turn (a position motor on the depth joint follows the
turn every tick), so turning the bulb clockwise seen from above screws it down and anticlockwise lifts it.
The pitch is a scaled-up thread (a real E27 lamp's is about 3.6 mm) so that one turn lowers the bulb by a
distance the cameras can see. Parallel-jaw gripper; RLBench's four cameras. Plan: ``grasp`` the bulb (jaws across
the ball), ``screw`` it one turn in ``SCREW_STROKES`` strokes (open, turn back, grasp again between strokes).
RLBench's version first carries the bulb from a holder to the lamp; here it starts in the socket.

Randomisation: the lamp 0.42-0.54 m from the base at a bearing within +-25 degrees, its yaw uniform; the bulb's
angle about its axis uniform.

Success: the bulb stands at most ``SCREWED_MAX`` (3 mm) out of its screwed-in position (it has been turned at
least 0.8 turn) and the gripper has let go of it, within the time limit.

Disturbances: none (the RLBench protocol injects none); the policy's own mistakes are the failures. Action
noise (``NOISE``): the grasp point of every (re-)grasp, each stroke's angle. Ground truth: ``policy_failure`` with
``what`` ``grasp_missed`` (a grasp closed on nothing of the bulb, so that stroke turns nothing) or
``screw_short`` (the bulb stands out more than ``SCREWED_MAX`` when the gripper lets go for the last time).
Expected failure signals: the bulb is not between the jaws after a grasp, or does not follow the gripper's turn
down; after the last stroke the bulb has not come down by the thread's depth.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.sim.tasks.base import TaskConfig, TaskResult
from code_as_monitor.sim.tasks.rlbench_base import RLBenchConfig, RLBenchTask

OBJ = "lamp"
THREAD_PITCH = 0.015  # metres the bulb goes down per turn
UNSCREWED = 0.015  # metres the bulb stands out at the start: one turn
SCREWED_MAX = 0.003  # success: at most this far out (0.8 turn screwed)
BALL_CENTRE = 0.022  # the glass ball's centre above the bulb link's frame, metres
GRASP_YAW = np.radians(80.0)  # tool yaw of the first grasp: the clockwise strokes then stay in the wrist's range
BULB_FRICTION = 0.02  # N m, the bulb's turning friction (a velocity motor with target 0)
THREAD_FORCE = 80.0  # newtons, the thread's position motor on the depth joint


@TaskConfig.register("screw-bulb")
@dataclass
class ScrewBulbConfig(RLBenchConfig):
    """``noise``: scale of the policy's action noise (0: the exact oracle)."""

    time_limit: float = 60.0


class ScrewBulb(RLBenchTask):
    instruction = "screw in the light bulb"
    NOISE: ClassVar[dict[str, float]] = {"grasp_xy": 0.013, "grasp_z": 0.004, "turn_rel": 0.18}

    def __init__(self, config: ScrewBulbConfig) -> None:
        super().__init__(config)
        self.depth_joint = -1
        self.turn_joint = -1
        self.turn0 = 0.0  # the bulb's angle when the thread's depth was UNSCREWED

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        body = pb.loadURDF(str(ASSETS / "lamp.urdf"), [0.5, 0.0, 0.0], useFixedBase=True, physicsClientId=c)
        links = {pb.getJointInfo(body, j, physicsClientId=c)[12].decode(): j
                 for j in range(pb.getNumJoints(body, physicsClientId=c))}
        self.depth_joint, self.turn_joint = links["thread"], links["bulb"]
        pb.setJointMotorControl2(body, self.turn_joint, pb.VELOCITY_CONTROL, targetVelocity=0.0,
                                 force=BULB_FRICTION, physicsClientId=c)
        for link in (-1, *links.values()):
            pb.changeDynamics(body, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        world.add_object(OBJ, [body], parts={"base": (body, -1), "socket": (body, links["socket"]),
                                             "bulb": (body, links["bulb"])}, graspable=True)

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        r, bearing = rng.uniform(0.42, 0.54), rng.uniform(-np.radians(25), np.radians(25))
        body = world.body_of(OBJ)
        pb.resetBasePositionAndOrientation(body, [r * np.cos(bearing), r * np.sin(bearing), 0.0],
                                           pb.getQuaternionFromEuler([0, 0, rng.uniform(-np.pi, np.pi)]),
                                           physicsClientId=c)
        self.turn0 = float(rng.uniform(-np.pi, np.pi))
        pb.resetJointState(body, self.turn_joint, self.turn0, 0.0, physicsClientId=c)
        pb.resetJointState(body, self.depth_joint, UNSCREWED, 0.0, physicsClientId=c)
        self._couple(world)

    def _couple(self, world: Any) -> None:
        """The thread: drive the depth joint to where the bulb's turn puts it."""
        import pybullet as pb

        c, body = world.client, world.body_of(OBJ)
        turn = pb.getJointState(body, self.turn_joint, physicsClientId=c)[0]
        depth = float(np.clip(UNSCREWED + THREAD_PITCH * (turn - self.turn0) / (2 * np.pi), 0.0, 0.02))
        pb.setJointMotorControl2(body, self.depth_joint, pb.POSITION_CONTROL, targetPosition=depth,
                                 force=THREAD_FORCE, physicsClientId=c)

    def on_tick(self, world: Any) -> None:
        self._couple(world)

    # --- interface used by the skills --------------------------------------------------------------------
    thread_pitch = THREAD_PITCH

    def out(self, world: Any) -> float:
        """Metres the bulb stands out of its screwed-in position (the depth joint)."""
        import pybullet as pb

        return float(pb.getJointState(world.body_of(OBJ), self.depth_joint, physicsClientId=world.client)[0])

    def grasp_centre(self, world: Any, obj: str, part: str = "") -> np.ndarray:
        """(3,) world grasp point: the bulb's glass ball's centre (else the part's bounding-box centre)."""
        if obj == OBJ and part == "bulb":
            T = world.pose(f"{OBJ}/bulb")
            return T[:3, 3] + T[:3, 2] * BALL_CENTRE
        import pybullet as pb

        b, link = world.objects[obj].parts.get(part, (world.body_of(obj), -1))
        lo, hi = pb.getAABB(b, link, physicsClientId=world.client)
        return (np.asarray(lo) + np.asarray(hi)) / 2

    def grasp_axis(self, world: Any, obj: str, part: str = "") -> np.ndarray:
        """(3,) the direction the jaws close across: for the round bulb, the one that gives the tool ``GRASP_YAW``."""
        return np.array([np.sin(GRASP_YAW), -np.cos(GRASP_YAW), 0.0])

    def grasp_yaw(self, world: Any, obj: str, part: str, current: float) -> float | None:
        """The bulb's grasp yaw exactly (not the nearest of the two jaw-symmetric ones): the strokes turn it down."""
        return float(GRASP_YAW) if part == "bulb" else None

    # --- ground truth ----------------------------------------------------------------------------------------
    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        if skill == "screw" and self.out(world) > SCREWED_MAX:
            return "screw_short"
        return super().judge(world, skill, args)

    def evaluate(self, world: Any) -> TaskResult:
        out = self.out(world)
        held = world.robot.ee.holding == world.body_of(OBJ)
        info = {"t": world.t, "out": out, "turned": (UNSCREWED - out) / THREAD_PITCH}
        if out > SCREWED_MAX:
            return TaskResult(False, f"the bulb stands {out * 1000:.0f} mm out of the socket "
                                     f"(at most {SCREWED_MAX * 1000:.0f} mm)", info)
        if held:
            return TaskResult(False, "the bulb is screwed in but still in the gripper", info)
        if world.t > self.config.time_limit + 1e-9:
            return TaskResult(False, f"screwed in after the time limit ({world.t:.1f} s)", info)
        return TaskResult(True, f"the bulb is screwed in ({out * 1000:.0f} mm out)", info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": OBJ, "part": "bulb"}),
            Action("screw", {"obj": OBJ, "turns": 1.0}),
        ]


ScrewBulbConfig.task_class = ScrewBulb
