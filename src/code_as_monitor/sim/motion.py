"""Smooth waypoint motion: minimum-jerk interpolation of the tool tip between Cartesian waypoints.

Every generator here yields once per control tick after setting the robot's motor targets; the
caller ticks the world. Positions are world metres, yaw radians, speeds m/s.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from code_as_monitor.sim.world import World

TRANSIT_SPEED = 0.4  # m/s, free-space moves
SLOW_SPEED = 0.15  # m/s, descending to contact / releasing
PUSH_SPEED = 0.25  # m/s, spatula strokes
YAW_RATE = 2.0  # rad/s
PITCH_RATE = 1.2  # rad/s, tilting a held object (gripper only)
WRIST_MARGIN = float(np.radians(20.0))  # least room the last wrist joint keeps to its limits at a new grasp yaw


def min_jerk(s: float) -> float:
    """Minimum-jerk time scaling: 0 -> 0, 1 -> 1 with zero velocity and acceleration at both ends."""
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def wrap_angle(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


class Mover:
    """Keeps the commanded tip pose and produces smooth moves from it."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.sync()

    def sync(self) -> None:
        """Reset the commanded pose to the measured one (after a halt or at start)."""
        self.tip = self.world.robot.tip().copy()
        self.yaw = self.world.robot.yaw()
        self.pitch = self.world.robot.pitch() if self.world.robot.ee.tilts else 0.0

    def move(self, target, yaw: float | None = None, speed: float = TRANSIT_SPEED, min_time: float = 0.15,
             pitch: float | None = None) -> Iterator[None]:
        """Move the tip from the commanded pose to ``target`` (3,), yaw to ``yaw`` and pitch to ``pitch``
        (None: keep; pitch only for a tilting tool)."""
        world = self.world
        target = np.asarray(target, dtype=float)
        start, y0, p0 = self.tip.copy(), self.yaw, self.pitch
        y1 = y0 if yaw is None else y0 + wrap_angle(yaw - y0)
        p1 = p0 if pitch is None or not world.robot.ee.tilts else float(pitch)
        dur = max(float(np.linalg.norm(target - start)) / speed, abs(y1 - y0) / YAW_RATE,
                  abs(p1 - p0) / PITCH_RATE, min_time)
        n = max(1, round(dur / world.dt))
        for k in range(1, n + 1):
            s = min_jerk(k / n)
            self.tip = start + s * (target - start)
            self.yaw = y0 + s * (y1 - y0)
            self.pitch = p0 + s * (p1 - p0)
            world.robot.move_tip(self.tip, self.yaw, self.pitch)
            yield

    def roomy_yaw(self, tip: Sequence[float] | np.ndarray, yaw: float, period: float) -> float:
        """The tool yaw to take at ``tip`` (3,) for a symmetric grasp: ``yaw`` itself (the caller's choice,
        nearest the current yaw) while the last wrist joint would keep :data:`WRIST_MARGIN` to its limits
        there, else the one of ``yaw + k * period`` (the equivalent yaws) that leaves it the most room.

        Always taking the equivalent yaw nearest the current one winds the wrist one way over many re-grasps
        until the joint sits on its limit; the solver then gives up the tip's position for the yaw (4.4 cm
        off a block at the Panda's 170 degrees, measured) and every pick that follows misses. The turn is
        logged as a ``wrist_turned`` event."""
        robot = self.world.robot
        tip = np.asarray(tip, dtype=float)
        room = robot.wrist_room(tip, yaw)
        if room >= WRIST_MARGIN:
            return yaw
        others = [yaw + k * period for k in range(1, max(1, round(2 * np.pi / period)))]
        best, best_room = max(((y, robot.wrist_room(tip, y)) for y in others), key=lambda x: x[1],
                              default=(yaw, room))
        if best_room <= room:
            return yaw
        self.world.events.log(self.world.t, "wrist_turned", yaw_from=float(yaw), yaw_to=float(best))
        return float(best)

    def wait(self, seconds: float) -> Iterator[None]:
        for _ in range(max(1, round(seconds / self.world.dt))):
            self.world.robot.hold()
            yield
