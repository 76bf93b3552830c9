"""End-effector elements in every tracker: they follow the robot's forward kinematics, never the images.

Elements owned by the robot (owner object ``"robot"`` by default, :attr:`.base.TrackerConfig.kinematic_owners`)
are placed by the observation's robot state: ``obs.robot.ee_points[part]`` when named there, else the
``ee_pose`` frame. World frame, metres.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import PerceptionError
from code_as_monitor.core.observation import Observation


class KinematicAnchor:
    """Moves an end-effector element with forward kinematics.

    At reset the element's points are stored relative to the anchor: the named point
    ``robot.ee_points[part]`` when present (pure translation), else the ``ee_pose`` frame.
    """

    def __init__(self, obs: Observation, element: Element) -> None:
        if obs.robot is None:
            raise PerceptionError(
                f"element {element.id} ({element.name!r}) belongs to the end-effector but the observation "
                "has no robot state"
            )
        self.part = element.owner[1] or "tip"
        robot = obs.robot
        if self.part in robot.ee_points:
            self.mode = "point"
            self.local = element.points - np.asarray(robot.ee_points[self.part], dtype=np.float64).reshape(1, 3)
        else:
            self.mode = "pose"
            T = np.asarray(robot.ee_pose, dtype=np.float64)
            self.local = (element.points - T[:3, 3]) @ T[:3, :3]
        self.name = element.name

    def points(self, obs: Observation) -> np.ndarray:
        """(k, 3) world points at ``obs``."""
        robot = obs.robot
        if robot is None:
            raise PerceptionError(f"element {self.name!r} follows the robot but the observation has no robot state")
        if self.mode == "point":
            if self.part not in robot.ee_points:
                raise PerceptionError(f"robot state lost its end-effector point {self.part!r}")
            return self.local + np.asarray(robot.ee_points[self.part], dtype=np.float64).reshape(1, 3)
        T = np.asarray(robot.ee_pose, dtype=np.float64)
        return self.local @ T[:3, :3].T + T[:3, 3]

    def observe(self, obs: Observation) -> tuple[np.ndarray, np.ndarray, int]:
        """(points (k, 3) at ``obs``, stale flags (k,) all False, number of views they project into): an
        anchored element is never stale, the robot state places it."""
        p = self.points(obs)
        return p, np.zeros(len(p), dtype=bool), views_containing(obs, p)


def views_containing(obs: Observation, points: np.ndarray) -> int:
    """Number of views of ``obs`` into whose image at least one of ``points`` (k, 3) projects."""
    n = 0
    for view in obs.views.values():
        cam = view.camera
        uv, z = cam.project(points)
        u, v = uv[:, 0], uv[:, 1]
        inside = (z > 0) & (u >= 0) & (u <= cam.width - 1) & (v >= 0) & (v <= cam.height - 1)
        n += bool(inside.any())
    return n
