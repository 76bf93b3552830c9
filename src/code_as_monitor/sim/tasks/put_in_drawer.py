"""``put-in-drawer`` (articulated object, RLBench's "put item in drawer"): open the drawer, put the block in it.

Description: the ``drawer_cabinet`` of ``open-drawer`` (parts ``frame``, ``drawer`` on its prismatic joint,
``handle``; ``assets/drawer_cabinet.urdf``) and a 4 cm ``block`` (parts ``body``, ``top``; ``assets/block.urdf``,
green) on the table beside it. Parallel-jaw gripper; RLBench's four cameras (front, left and right shoulder,
wrist; :func:`code_as_monitor.sim.cameras.rlbench_cameras`). Plan: ``grasp`` the handle, ``pull`` the drawer
out ``PULL_DISTANCE``, ``grasp`` the block, ``put_in`` the drawer (over the open part of the tray, lowered to
``PUT_CLEARANCE`` above its floor, released).

Randomisation: the cabinet as in ``open-drawer`` (handle 0.46-0.54 m from the base at a bearing within
+-20 degrees, front facing the base within +-15 degrees); the block 0.36-0.46 m from the base at a bearing
32-42 degrees to one side (random) of the handle's, yaw uniform.

Success: the block's centre is inside the drawer's tray (the tray's inner box in the drawer link's frame, up to
1 cm above its walls) and the gripper does not hold it, within the time limit.

Disturbances: none (the RLBench protocol injects none); the policy's own mistakes are the failures. Action
noise (``NOISE``, scaled by ``noise``): grasp offsets (handle and block), the pull's length, the drop point.
Ground truth: ``policy_failure`` with ``what`` ``grasp_missed`` (the jaws closed on nothing of the object),
``pull_short`` (released with the drawer open less than ``OPEN_NEEDED``), ``item_misplaced`` (the released
block is not in the tray).
Expected failure signals: the handle or the block is not between the jaws after a grasp; the drawer front has
come out less than needed after the pull; the released block is not inside the drawer's tray.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.sim.tasks.base import TaskConfig, TaskResult
from code_as_monitor.sim.tasks.open_drawer import OBJ, load_cabinet, place_cabinet
from code_as_monitor.sim.tasks.rlbench_base import RLBenchConfig, RLBenchTask

ITEM = "block"
PULL_DISTANCE = 0.17  # metres, as open-drawer's pull
OPEN_NEEDED = 0.055  # metres: the open part of the tray must take the 4 cm block (measured: 6.7 cm took it)
TRAY = {"x": (-0.212, 0.0), "y": (-0.112, 0.112), "z": (-0.059, -0.010)}
"""The tray's inner box in the drawer link's frame (assets/drawer_cabinet.urdf): x from the back wall to the front
plate, y between the side walls, z from the floor's top to 1 cm above the walls' top."""
TRAY_FLOOR = -0.059  # the tray floor's top, drawer link frame
FRONT_FACE = 0.13  # the cabinet frame's front face, cabinet frame x
FRAME_TOP = 0.10  # the cabinet's top, metres above the table


def in_tray(point_drawer: np.ndarray) -> bool:
    """Is ``point_drawer`` (3,), a point in the drawer link's frame, inside the tray (``TRAY``)?"""
    p = np.asarray(point_drawer, float)
    return all(lo <= p[i] <= hi for i, (lo, hi) in enumerate(TRAY.values()))


@TaskConfig.register("put-in-drawer")
@dataclass
class PutInDrawerConfig(RLBenchConfig):
    """``noise``: scale of the policy's action noise (0: the exact oracle)."""

    time_limit: float = 60.0


class PutInDrawer(RLBenchTask):
    instruction = "open the drawer and put the block in it"
    NOISE: ClassVar[dict[str, float]] = {"grasp_xy": 0.008, "grasp_z": 0.003, "grasp_yaw": 0.05, "pull_rel": 0.08,
                                         "place_xy": 0.04}

    def __init__(self, config: PutInDrawerConfig) -> None:
        super().__init__(config)
        self.joint = -1

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        self.joint = load_cabinet(world)
        c = world.client
        b = pb.loadURDF(str(ASSETS / "block.urdf"), [0.4, 0.3, 0.02], physicsClientId=c)
        for link in (-1, 0):
            pb.changeVisualShape(b, link, rgbaColor=[0.2, 0.7, 0.3, 1], physicsClientId=c)
            pb.changeDynamics(b, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        world.add_object(ITEM, [b], parts={"body": (b, -1), "top": (b, 0)}, graspable=True)

    def reset(self, world: Any) -> None:
        import pybullet as pb

        bearing = place_cabinet(world, self.joint)
        rng = world.rng
        side = rng.choice([-1.0, 1.0])
        a = bearing + side * np.radians(rng.uniform(32.0, 42.0))
        r = rng.uniform(0.36, 0.46)
        pb.resetBasePositionAndOrientation(world.body_of(ITEM), [r * np.cos(a), r * np.sin(a), 0.02],
                                           pb.getQuaternionFromEuler([0, 0, rng.uniform(-np.pi, np.pi)]),
                                           physicsClientId=world.client)

    # --- interface used by the skills --------------------------------------------------------------------
    def opening(self, world: Any) -> float:
        """The drawer's joint position: metres it is pulled out of the frame (0 closed)."""
        import pybullet as pb

        return float(pb.getJointState(world.body_of(OBJ), self.joint, physicsClientId=world.client)[0])

    def pull_axis(self, world: Any, obj: str) -> np.ndarray:
        """(3,) world unit direction in which the drawer opens (the cabinet's local +x)."""
        return world.pose(OBJ)[:3, 0].copy()

    def grasp_axis(self, world: Any, obj: str, part: str = "") -> np.ndarray:
        """(3,) world direction the jaws close across: the handle's bar, else the object's local x."""
        if obj == OBJ and part == "handle":
            return world.pose(f"{OBJ}/handle")[:3, 1].copy()
        return world.pose(obj)[:3, 0].copy()

    def drop_point(self, world: Any, target: str) -> np.ndarray:
        """(3,) world point on the tray's floor at the middle of its open part (out of the frame), metres."""
        T = world.pose(OBJ)
        x = FRONT_FACE + self.opening(world) / 2
        floor = world.pose(f"{OBJ}/drawer")[2, 3] + TRAY_FLOOR
        p = T[:3, :3] @ np.array([x, 0.0, 0.0]) + T[:3, 3]
        return np.array([p[0], p[1], floor])

    def drawer_top(self, world: Any, target: str) -> float:
        """Height of the cabinet's top (metres): the held block is carried above it."""
        return FRAME_TOP

    def item_in_tray(self, world: Any) -> bool:
        T = world.pose(f"{OBJ}/drawer")
        p = T[:3, :3].T @ (world.position(ITEM) - T[:3, 3])
        return in_tray(p)

    # --- ground truth ----------------------------------------------------------------------------------------
    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        if skill == "pull" and self.opening(world) < OPEN_NEEDED:
            return "pull_short"
        if skill == "put_in" and not self.item_in_tray(world):
            return "item_misplaced"
        return super().judge(world, skill, args)

    def evaluate(self, world: Any) -> TaskResult:
        inside = self.item_in_tray(world)
        held = world.robot.ee.holding == world.body_of(ITEM)
        q = self.opening(world)
        info = {"t": world.t, "opening": q, "in_tray": inside, "block": world.position(ITEM).tolist()}
        if not inside:
            return TaskResult(False, f"the block is not in the drawer (open {q * 100:.1f} cm)", info)
        if held:
            return TaskResult(False, "the block is in the drawer but still in the gripper", info)
        if world.t > self.config.time_limit + 1e-9:
            return TaskResult(False, f"put in after the time limit ({world.t:.1f} s)", info)
        return TaskResult(True, f"the block is in the drawer (open {q * 100:.1f} cm)", info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": OBJ, "part": "handle"}),
            Action("pull", {"obj": OBJ, "distance": PULL_DISTANCE}),
            Action("grasp", {"obj": ITEM}),
            Action("put_in", {"obj": ITEM, "target": OBJ}),
        ]


PutInDrawerConfig.task_class = PutInDrawer
