"""``drag-stick`` (tool use, RLBench's "drag stick"): use the stick to drag the cube onto the red target.

Description: a ``stick`` (``assets/stick.urdf``; parts ``shaft`` and ``grip``, 38 cm long) lies on the table, a
4 cm ``cube`` (parts ``body``, ``top``; ``assets/block.urdf``, blue) stands out of easy reach beyond a red
``target`` square (part ``surface``, 10 cm, flat, ``assets/target.urdf``) that lies between the cube and the
robot. Parallel-jaw gripper; RLBench's four cameras. Plan: ``grasp`` the stick by its grip, ``drag``: turn it
across the drag direction, lower it onto the table just beyond the cube, pull it towards the target so that the
shaft drags the cube along, back off, put the stick down and park.

Randomisation: the cube 0.56-0.63 m from the base at a bearing within +-15 degrees, yaw uniform; the target
0.16-0.21 m nearer the base along the cube's bearing, shifted sideways by up to 4 cm; the stick 0.30-0.36 m out
from the base and 0.22-0.26 m to one side (random), pointing away from the base within +-15 degrees.

Success: the cube's centre is over the target square and the cube rests on the table, within the time limit.

Disturbances: none (the RLBench protocol injects none); the policy's own mistakes are the failures. Action
noise (``NOISE``): the grasp point, where the stick comes down behind the cube, the drag's length. Ground truth:
``policy_failure`` with ``what`` ``grasp_missed`` (the jaws closed on nothing of the stick) or
``cube_off_target`` (the drag ended with the cube's centre off the target).
Expected failure signals: the stick is not in the gripper after the grasp; the cube does not move with the
stick during the drag; after the drag the cube is not on the target.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.sim.tasks.base import TaskConfig, TaskResult
from code_as_monitor.sim.tasks.rlbench_base import RLBenchConfig, RLBenchTask

STICK, CUBE, TARGET = "stick", "cube", "target"
CUBE_HALF = 0.02
STICK_HALF = 0.01  # half the shaft's width
TARGET_HALF = 0.05  # half the target square's side
SOLVER_ITERATIONS = 100
STICK_CONTACT = -0.04  # the shaft's local x (metres) that meets the cube: 15 cm from the grip's centre


def on_target(cube_xy: np.ndarray, target_pose: np.ndarray) -> bool:
    """Is the cube's centre ``cube_xy`` (2,) over the target square whose (4, 4) world pose is ``target_pose``?"""
    d = np.asarray(cube_xy, float)[:2] - target_pose[:2, 3]
    local = target_pose[:2, :2].T @ d
    return bool(np.all(np.abs(local) <= TARGET_HALF))


@TaskConfig.register("drag-stick")
@dataclass
class DragStickConfig(RLBenchConfig):
    """``noise``: scale of the policy's action noise (0: the exact oracle)."""

    time_limit: float = 40.0


class DragStick(RLBenchTask):
    instruction = "use the stick to drag the cube onto the red target"
    NOISE: ClassVar[dict[str, float]] = {"grasp_xy": 0.006, "grasp_z": 0.003, "grasp_yaw": 0.05,
                                         "contact_xy": 0.007, "drag_rel": 0.15}
    stick_contact = STICK_CONTACT

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        # a held stick hangs off a chain (arm -> tool -> stick, 15-30 cm of lever) that the default 20 solver
        # iterations leave soft: the stick drooped about 6 degrees in the grasp and pivoted when it met the
        # table (measured); pour-tea has the same chain and the same remedy
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=c)
        stick = pb.loadURDF(str(ASSETS / "stick.urdf"), [0.33, 0.24, 0.01], physicsClientId=c)
        cube = pb.loadURDF(str(ASSETS / "block.urdf"), [0.6, 0.0, 0.02], physicsClientId=c)
        target = pb.loadURDF(str(ASSETS / "target.urdf"), [0.42, 0.0, 0.0], useFixedBase=True, physicsClientId=c)
        for link in (-1, 0):
            pb.changeVisualShape(cube, link, rgbaColor=[0.2, 0.4, 0.9, 1], physicsClientId=c)
            pb.changeDynamics(cube, link, lateralFriction=0.5, restitution=0.0, physicsClientId=c)
            pb.changeDynamics(stick, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        world.add_object(STICK, [stick], parts={"shaft": (stick, -1), "grip": (stick, 0)}, graspable=True)
        world.add_object(CUBE, [cube], parts={"body": (cube, -1), "top": (cube, 0)})
        world.add_object(TARGET, [target], parts={"surface": (target, -1)})

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        r, bearing = rng.uniform(0.56, 0.63), rng.uniform(-np.radians(15), np.radians(15))
        out = np.array([np.cos(bearing), np.sin(bearing)])
        side = np.array([-out[1], out[0]])
        cube = r * out
        target = cube - rng.uniform(0.16, 0.21) * out + rng.uniform(-0.04, 0.04) * side
        s = rng.choice([-1.0, 1.0])
        stick = np.array([rng.uniform(0.34, 0.40), s * rng.uniform(0.20, 0.24)])
        q = pb.getQuaternionFromEuler
        pb.resetBasePositionAndOrientation(world.body_of(CUBE), [*cube, CUBE_HALF],
                                           q([0, 0, rng.uniform(-np.pi, np.pi)]), physicsClientId=c)
        pb.resetBasePositionAndOrientation(world.body_of(TARGET), [*target, 0.0], q([0, 0, bearing]),
                                           physicsClientId=c)
        # the shaft's centre 0.19 m beyond the grip's along the stick's +x (away from the base)
        yaw = float(np.arctan2(stick[1], stick[0])) + rng.uniform(-np.radians(15), np.radians(15))
        centre = stick + 0.19 * np.array([np.cos(yaw), np.sin(yaw)])
        pb.resetBasePositionAndOrientation(world.body_of(STICK), [*centre, STICK_HALF], q([0, 0, yaw]),
                                           physicsClientId=c)

    # --- interface used by the skills --------------------------------------------------------------------
    def drag_gap(self, world: Any, target: str, tool: str, direction: np.ndarray) -> float:
        """Distance (metres, along the drag ``direction`` (2,)) from the cube's centre to the stick's centreline
        where the stick comes down behind the cube: 1 cm clear of the cube's extent along the drag (a turned
        cube reaches up to 2.8 cm from its centre)."""
        R = world.pose(target)[:2, :2]
        extent = CUBE_HALF * float(np.sum(np.abs(R.T @ np.asarray(direction, float)[:2])))
        return extent + STICK_HALF + 0.01

    # --- ground truth ----------------------------------------------------------------------------------------
    def cube_on_target(self, world: Any) -> bool:
        return on_target(world.position(CUBE)[:2], world.pose(TARGET))

    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        if skill == "drag" and not self.cube_on_target(world):
            return "cube_off_target"
        return super().judge(world, skill, args)

    def evaluate(self, world: Any) -> TaskResult:
        p = world.position(CUBE)
        d = float(np.linalg.norm(p[:2] - world.position(TARGET)[:2]))
        info = {"t": world.t, "cube": p.tolist(), "to_target": d}
        if not self.cube_on_target(world):
            return TaskResult(False, f"the cube is {d * 100:.1f} cm from the target's centre, off the target", info)
        if p[2] > CUBE_HALF + 0.01:
            return TaskResult(False, "the cube is over the target but not resting on the table", info)
        if world.t > self.config.time_limit + 1e-9:
            return TaskResult(False, f"dragged after the time limit ({world.t:.1f} s)", info)
        return TaskResult(True, f"the cube is on the target ({d * 100:.1f} cm from its centre)", info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": STICK, "part": "grip"}),
            Action("drag", {"obj": STICK, "target": CUBE, "goal": TARGET}),
        ]


DragStickConfig.task_class = DragStick
