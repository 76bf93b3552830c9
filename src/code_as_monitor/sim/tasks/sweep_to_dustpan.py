"""``sweep-to-dustpan`` (tool use, RLBench's "sweep to dustpan"): sweep the dirt into the dustpan with the broom.

Description: a ``broom`` (``assets/broom.urdf``; parts ``handle`` and ``head``) lies on the table near the
robot; ``N_DIRT`` dirt cubes (``dirt_0`` ... ``dirt_4``, 2 cm, brown; ``assets/small_block.urdf``) lie in a small
heap; a ``dustpan`` (``assets/dustpan.urdf``, fixed; parts ``pan``, its 2 mm floor whose front edge is the
opening's lip, and ``walls``) stands 0.19-0.23 m beside the heap with its opening towards it. Parallel-jaw
gripper; RLBench's four cameras. Plan: ``grasp`` the broom by its handle, ``sweep``: turn it so that the head
faces the dustpan, lower the head onto the table behind the heap, push it across the lip into the pan, lift
(the broom stays in the gripper) and park.

Randomisation: the dustpan's floor centre 0.48-0.56 m out from the base, on a random side, 0.14-0.18 m off the
base's axis, opening towards the heap; the heap's centre 0.19-0.23 m from the pan's centre towards the other
side, 5 cubes on 5 of the 9 points of a 2.8 cm grid (jittered by up to 3 mm), yaws uniform; the broom's handle
centre 0.28-0.32 m out and 0.17-0.21 m to the heap's side, head away from the base within +-15 degrees.

Success: at least ``DIRT_MIN`` (4) of the 5 dirt cubes are in the dustpan (their centres over its floor, inside
its walls), within the time limit.

Disturbances: none (the RLBench protocol injects none); the policy's own mistakes are the failures. Action
noise (``NOISE``): the grasp point, where the head comes down behind the heap, the stroke's length. Ground truth:
``policy_failure`` with ``what`` ``grasp_missed`` (the jaws closed on nothing of the broom) or ``dirt_left``
(after the stroke fewer than ``DIRT_MIN`` cubes are in the pan).
Expected failure signals: the broom is not in the gripper after the grasp; cubes are left outside the pan after
the stroke (counted against the pan's floor, a surface element).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.sim.tasks.base import TaskConfig, TaskResult
from code_as_monitor.sim.tasks.rlbench_base import RLBenchConfig, RLBenchTask

BROOM, PAN = "broom", "dustpan"
N_DIRT = 5
DIRT_MIN = 4
DIRT_HALF = 0.01
PAN_INSIDE = {"x": (-0.06, 0.07), "y": (-0.09, 0.09)}
"""The pan's floor inside its walls, in the pan's frame (x out of the opening), metres."""
HEAD_HALF_DEPTH = 0.015  # half the broom head's depth along the stroke
SOLVER_ITERATIONS = 100  # a held broom: the same soft arm -> tool -> tool chain as drag-stick's


def dirt_in_pan(points: np.ndarray, pan_pose: np.ndarray) -> np.ndarray:
    """(N,) bool: is each dirt centre of ``points`` (N, 3) world over the pan's floor inside its walls (``pan_pose``
    (4, 4) world, the floor's centre at its bottom), and no more than 3 cm above it?"""
    P = (np.asarray(points, float).reshape(-1, 3) - pan_pose[:3, 3]) @ pan_pose[:3, :3]
    (x0, x1), (y0, y1) = PAN_INSIDE.values()
    return (P[:, 0] >= x0) & (P[:, 0] <= x1) & (P[:, 1] >= y0) & (P[:, 1] <= y1) & (P[:, 2] <= 0.03)


@TaskConfig.register("sweep-to-dustpan")
@dataclass
class SweepToDustpanConfig(RLBenchConfig):
    """``noise``: scale of the policy's action noise (0: the exact oracle)."""

    time_limit: float = 40.0


class SweepToDustpan(RLBenchTask):
    instruction = "sweep the dirt into the dustpan"
    NOISE: ClassVar[dict[str, float]] = {"grasp_xy": 0.006, "grasp_z": 0.003, "grasp_yaw": 0.05,
                                         "contact_xy": 0.012, "sweep_rel": 0.10}
    dirt_names = tuple(f"dirt_{i}" for i in range(N_DIRT))
    dirt_half = DIRT_HALF
    head_half_depth = HEAD_HALF_DEPTH

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=c)
        broom = pb.loadURDF(str(ASSETS / "broom.urdf"), [0.32, 0.12, 0.01], physicsClientId=c)
        pan = pb.loadURDF(str(ASSETS / "dustpan.urdf"), [0.52, -0.16, 0.0], useFixedBase=True, physicsClientId=c)
        for b in (broom, pan):
            for link in (-1, 0):
                pb.changeDynamics(b, link, lateralFriction=0.5, restitution=0.0, physicsClientId=c)
        world.add_object(BROOM, [broom], parts={"handle": (broom, -1), "head": (broom, 0)}, graspable=True)
        world.add_object(PAN, [pan], parts={"pan": (pan, -1), "walls": (pan, 0)})
        for i, name in enumerate(self.dirt_names):
            b = pb.loadURDF(str(ASSETS / "small_block.urdf"), [0.5, 0.05 * i, 0.01], physicsClientId=c)
            pb.changeVisualShape(b, -1, rgbaColor=[0.45, 0.3, 0.15, 1], physicsClientId=c)
            pb.changeDynamics(b, -1, lateralFriction=0.5, restitution=0.0, physicsClientId=c)
            world.add_object(name, [b])

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        q = pb.getQuaternionFromEuler
        side = rng.choice([-1.0, 1.0])  # the pan's side (+1: +y)
        pan = np.array([rng.uniform(0.48, 0.56), side * rng.uniform(0.14, 0.18)])
        # the pan's +x (out of the opening) towards the heap: world -side*y
        pb.resetBasePositionAndOrientation(world.body_of(PAN), [*pan, 0.0], q([0, 0, -side * np.pi / 2]),
                                           physicsClientId=c)
        heap = pan + np.array([rng.uniform(-0.02, 0.02), -side * rng.uniform(0.19, 0.23)])
        grid = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], float) * 0.028
        picks = rng.choice(len(grid), size=N_DIRT, replace=False)
        for name, k in zip(self.dirt_names, picks):
            p = heap + grid[k] + rng.uniform(-0.003, 0.003, size=2)
            pb.resetBasePositionAndOrientation(world.body_of(name), [*p, DIRT_HALF],
                                               q([0, 0, rng.uniform(-np.pi, np.pi)]), physicsClientId=c)
        handle = np.array([rng.uniform(0.28, 0.32), -side * rng.uniform(0.17, 0.21)])
        yaw = rng.uniform(-np.radians(15), np.radians(15))  # head (+x) away from the base
        pb.resetBasePositionAndOrientation(world.body_of(BROOM), [*handle, 0.008], q([0, 0, yaw]),
                                           physicsClientId=c)

    # --- interface used by the skills --------------------------------------------------------------------
    def pan_point(self, world: Any, target: str) -> np.ndarray:
        """(3,) world point where the head's front face should stop: 2 cm behind the pan floor's centre."""
        T = world.pose(PAN)
        return T[:3, :3] @ np.array([-0.02, 0.0, 0.0]) + T[:3, 3]

    def grasp_yaw(self, world: Any, obj: str, part: str, current: float) -> float | None:
        """Of the two jaw-symmetric yaws for the broom's handle, one from which the sweep's turn (head towards the
        pan) ends inside the wrist's range; the nearer to ``current`` when both do."""
        if obj != BROOM:
            return None
        from code_as_monitor.sim.rlbench_skills import YAW_RANGE

        axis = world.pose(BROOM)[:3, 0]
        base = float(np.arctan2(axis[0], -axis[1]))  # jaws across the handle
        dirt = np.array([world.position(n)[:2] for n in self.dirt_names]).mean(axis=0)
        d = self.pan_point(world, PAN)[:2] - dirt
        turn = float((np.arctan2(d[1], d[0]) - np.arctan2(axis[1], axis[0]) + np.pi) % (2 * np.pi) - np.pi)
        options = [y for y in (base, base + np.pi, base - np.pi) if abs(y) <= np.pi]
        fits = [y for y in options if YAW_RANGE[0] <= y + turn <= YAW_RANGE[1] and YAW_RANGE[0] <= y <= YAW_RANGE[1]]
        return min(fits or options, key=lambda y: abs(y - current))

    # --- ground truth ----------------------------------------------------------------------------------------
    def dirt_points(self, world: Any) -> np.ndarray:
        return np.array([world.position(n) for n in self.dirt_names])

    def n_in_pan(self, world: Any) -> int:
        return int(np.sum(dirt_in_pan(self.dirt_points(world), world.pose(PAN))))

    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        if skill == "sweep" and self.n_in_pan(world) < DIRT_MIN:
            return "dirt_left"
        return super().judge(world, skill, args)

    def evaluate(self, world: Any) -> TaskResult:
        n = self.n_in_pan(world)
        info = {"t": world.t, "in_pan": n, "n": N_DIRT}
        if n < DIRT_MIN:
            return TaskResult(False, f"{n} of {N_DIRT} dirt cubes in the dustpan (needs {DIRT_MIN})", info)
        if world.t > self.config.time_limit + 1e-9:
            return TaskResult(False, f"swept after the time limit ({world.t:.1f} s)", info)
        return TaskResult(True, f"{n} of {N_DIRT} dirt cubes in the dustpan", info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": BROOM, "part": "handle"}),
            Action("sweep", {"obj": BROOM, "target": PAN}),
        ]


SweepToDustpanConfig.task_class = SweepToDustpan
