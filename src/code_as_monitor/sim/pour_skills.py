"""Scripted skills for ``pour-tea`` (oracle, open loop).

Mixed into :class:`~code_as_monitor.sim.policies.ScriptedPolicy`. Like the other gripper skills, each one
computes its targets from the ground-truth poses when it starts and then plays smooth moves without looking
again: a pot that tips over in the grasp on the way is carried on tipped.

The held pot's geometry is read in the tool frame when a skill starts: its up axis ``u`` and its spout
direction ``v`` (the pot's +x). The wrist pitch ``p`` (see :func:`code_as_monitor.sim.robot.down_quat`)
turns the pot about the tool's closing axis; the pot is level at ``p = atan2(-u_y, -u_z)`` (when ``u`` has
no component along the closing axis; otherwise as level as the pitch can make it) and tilted by ``a``
towards the spout at the level pitch plus or minus ``a``, whichever lowers the spout.

Skills (``Action.skill``, ``Action.args``):

- ``transport {"obj", "target"}``: carry the held pot at its current pitch, turned to the yaw the pour will
  use (:func:`~code_as_monitor.sim.gripper_skills.tilted_yaw`, inside the wrist's limits), until the spout's
  end is ``TRANSPORT_CLEAR`` above the centre of the target's rim.
- ``pour {"obj", "target"}``: tilt the pot to ``POUR_TILT`` from level, pivoting about the spout's end, which
  moves to ``POUR_CLEAR`` above the rim's centre (``POUR_AIM_BACK`` short of it). The tea runs out of the spout
  once the trough slopes down.
- ``drain {"obj", "target"}``: hold the pose for ``DRAIN_S`` seconds while the tea runs out.
- ``level {"obj"}``: turn the wrist so that the held pot is level again (tea left in the spout rolls back).
- ``set_down {"obj"}``: carry the held pot to a free spot of table at least ``SET_DOWN_AWAY`` from the cup
  (the object named ``teacup`` when there is one), lower it until its lowest point is ``SET_DOWN_GAP`` above
  the table, open the fingers and lift: a pot tipped in the grasp lands on its floor, level.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from code_as_monitor.sim.gripper_skills import GRIP_CARRY_Z, tilted_yaw
from code_as_monitor.sim.motion import PITCH_RATE, SLOW_SPEED, min_jerk

POUR_SKILLS: dict[str, tuple[tuple[str, ...], str]] = {
    "transport": (("obj", "target"), "gripper"),
    "pour": (("obj", "target"), "gripper"),
    "drain": (("obj", "target"), "gripper"),
    "level": (("obj",), "gripper"),
    "set_down": (("obj",), "gripper"),
}
"""Skill -> (required args naming objects, end-effector kind)."""

POUR_TILT = np.radians(70.0)  # pour tilt from level, radians: the 35-degree spout trough then slopes down 35 degrees
TRANSPORT_CLEAR = 0.08  # spout end above the rim at the end of transport, metres (the pot's bottom clears the rim)
POUR_CLEAR = 0.015  # spout end above the rim while pouring, metres (a short fall keeps the stream in the cup)
POUR_RATE = 0.6 * PITCH_RATE  # rad/s: a slower tilt than a free reorientation, so the tea does not surge
DRAIN_S = 2.5  # seconds held tilted: 30 particles run out of the spout in about 1.5 s (measured)
POUR_AIM_BACK = 0.015  # metres: the spout end aims this far short of the rim centre (the stream leaves forwards)
SET_DOWN_AWAY = 0.17  # metres between the pot's and the cup's centres when setting the pot down
SET_DOWN_GAP = 0.008  # metres above the table at release


def tool_rotation(yaw: float, pitch: float) -> np.ndarray:
    """(3, 3) world rotation of the tool frame for ``yaw`` and ``pitch`` (radians): Rz(yaw) Rx(pi) Rx(pitch)."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, -cp, sp], [0.0, -sp, -cp]])  # Rx(pi) @ Rx(pitch)
    return Rz @ Rx


def level_pitch(up_tool: np.ndarray) -> float:
    """Wrist pitch (radians) that makes the held object's up axis (``up_tool`` (3,), tool frame) most vertical."""
    return float(np.arctan2(-up_tool[1], -up_tool[2]))


def pour_pitch(up_tool: np.ndarray, spout_tool: np.ndarray, tilt: float) -> float:
    """Wrist pitch (radians) that tilts the held pot ``tilt`` radians from level with its spout (direction
    ``spout_tool`` (3,), tool frame) going down."""
    p0 = level_pitch(up_tool)
    cands = [p0 + tilt, p0 - tilt]
    z = [-(np.sin(p) * spout_tool[1] + np.cos(p) * spout_tool[2]) for p in cands]  # spout's world z component
    return float(cands[int(np.argmin(z))])


class PourSkills:
    """Skill generators for ``pour-tea``; expects ``world``, ``task``, ``mover``, ``_aabb`` and ``_lift``."""

    world: Any
    task: Any
    mover: Any

    # --- helpers -------------------------------------------------------------------------------------
    def _held_axes(self, obj: str) -> tuple[np.ndarray, np.ndarray]:
        """The held object's up (local z) and spout (local x) axes in the tool frame, (3,) each."""
        R_tool = self.world.robot.ee_pose()[:3, :3]
        T = self.world.pose(obj)
        return R_tool.T @ T[:3, 2], R_tool.T @ T[:3, 0]

    def _spout_in_tool(self) -> np.ndarray:
        """(3,) the spout's end relative to the tool tip, in the tool frame (fixed while the pot is held)."""
        T_tool = self.world.robot.ee_pose()
        return T_tool[:3, :3].T @ (self.task.spout_end(self.world) - T_tool[:3, 3])

    def _rim(self, target: str) -> tuple[np.ndarray, float]:
        """(2,) the centre of ``target``'s rim and the rim's top height, metres."""
        lo, hi = self._aabb(f"{target}/rim")  # type: ignore[attr-defined]
        return (lo[:2] + hi[:2]) / 2, float(hi[2])

    def _pivot(self, spout_tool: np.ndarray, end: np.ndarray, pitch: float, rate: float) -> Iterator[None]:
        """Turn the wrist to ``pitch`` (yaw kept) while the spout's end moves straight to ``end`` (3,)."""
        world, mv = self.world, self.mover
        p0, yaw = mv.pitch, mv.yaw
        s0 = mv.tip + tool_rotation(yaw, p0) @ spout_tool
        dur = max(abs(pitch - p0) / rate, float(np.linalg.norm(end - s0)) / SLOW_SPEED, 0.15)
        n = max(1, round(dur / world.dt))
        for k in range(1, n + 1):
            s = min_jerk(k / n)
            p = p0 + s * (pitch - p0)
            mv.pitch = p
            mv.tip = s0 + s * (end - s0) - tool_rotation(yaw, p) @ spout_tool
            world.robot.move_tip(mv.tip, yaw, p)
            yield

    # --- skills ----------------------------------------------------------------------------------------
    def _transport(self, obj: str, target: str) -> Iterator[None]:
        up, spout = self._held_axes(obj)
        st = self._spout_in_tool()
        centre, rim_top = self._rim(target)
        yaw = tilted_yaw(np.array([*centre, 0.0]), pour_pitch(up, spout, POUR_TILT))
        end = np.array([*centre, rim_top + TRANSPORT_CLEAR])
        tip = end - tool_rotation(yaw, self.mover.pitch) @ st
        high = max(GRIP_CARRY_Z, float(tip[2]))
        yield from self._lift(high)  # type: ignore[attr-defined]
        yield from self.mover.move([*tip[:2], high], yaw)
        yield from self.mover.move(tip, speed=SLOW_SPEED * 2)

    def _pour(self, obj: str, target: str) -> Iterator[None]:
        up, spout = self._held_axes(obj)
        centre, rim_top = self._rim(target)
        pitch = pour_pitch(up, spout, POUR_TILT)
        st = self._spout_in_tool()
        fwd = tool_rotation(self.mover.yaw, pitch) @ (st / max(float(np.linalg.norm(st)), 1e-9))
        fwd = fwd[:2] / max(float(np.linalg.norm(fwd[:2])), 1e-9)  # horizontal direction from the grasp to the spout
        aim = np.array([*(centre - POUR_AIM_BACK * fwd), rim_top + POUR_CLEAR])
        yield from self._pivot(st, aim, pitch, POUR_RATE)

    def _drain(self, obj: str, target: str) -> Iterator[None]:
        yield from self.mover.wait(DRAIN_S)

    def _level(self, obj: str) -> Iterator[None]:
        up, _ = self._held_axes(obj)
        yield from self.mover.move(self.mover.tip, pitch=level_pitch(up), speed=SLOW_SPEED)

    def _set_down(self, obj: str) -> Iterator[None]:
        lo, _ = self._aabb(obj)  # type: ignore[attr-defined]
        tip = self.world.robot.tip()
        drop = float(tip[2] - lo[2])  # grasp point above the pot's lowest point
        xy = self.world.position(obj)[:2]
        off = tip[:2] - xy
        if "teacup" in self.world.objects:
            cup = self.world.position("teacup")[:2]
            d = xy - cup
            dist = float(np.linalg.norm(d))
            if dist < SET_DOWN_AWAY:
                u = d / dist if dist > 1e-6 else np.array([0.0, 1.0])
                xy = cup + u * SET_DOWN_AWAY
        goal = xy + off
        high = max(GRIP_CARRY_Z, float(tip[2]))
        yield from self._lift(high)  # type: ignore[attr-defined]
        yield from self.mover.move([*goal, high])
        yield from self.mover.move([*goal, drop + SET_DOWN_GAP], speed=SLOW_SPEED)
        yield from self.mover.wait(0.1)
        self._grip_open()  # type: ignore[attr-defined]
        yield from self.mover.wait(0.3)
        yield from self.mover.move([*goal, high], speed=SLOW_SPEED * 2, pitch=0.0)
