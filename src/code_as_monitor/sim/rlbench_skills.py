"""Scripted skills of the RLBench-style tasks (put-in-drawer, screw-bulb, turn-tap, drag-stick, sweep-to-dustpan).

Mixed into :class:`~code_as_monitor.sim.policies.ScriptedPolicy`, after the gripper skills (``grasp``) and the
drawer skill (``pull``) they follow. Like every scripted skill, each one reads the ground-truth poses when it
starts (a stroke of ``screw`` when it starts) and then plays smooth moves without looking again. Unlike the
others, these tasks run the policy with action noise (:mod:`code_as_monitor.sim.action_noise`): the decisions
named below are perturbed as a learned policy would get them slightly wrong, and the task judges each outcome
(``task.judge``), logging the first one that failed as a ``policy_failure`` event (see ``ScriptedPolicy._judge``).

Skills (``Action.skill``, ``Action.args``), with their noisy decisions in brackets:

- ``put_in {"obj": item, "target": cabinet}``: carry the held item above the open part of the drawer's tray,
  lower it until its bottom is ``PUT_CLEARANCE`` above the tray's floor, open, retreat up and park
  [``place_xy``: the drop point].
- ``screw {"obj": lamp, "turns": n}``: with the bulb in the gripper, turn it clockwise (seen from above) in
  ``SCREW_STROKES`` strokes of ``n`` turns in all, following the thread down; between strokes open, turn back
  and grasp again; open and park [``grasp_xy``/``grasp_z`` each re-grasp, ``turn_rel`` each stroke's angle].
- ``turn {"obj": tap, "part": handle, "angle": degrees}``: turn the grasped lever about its hinge (the tool tip
  follows the arc, the yaw follows the lever), outwards (``task.turn_sign``), open, lift, park
  [``turn_rel``: the angle].
- ``drag {"obj": stick, "target": cube, "goal": target}``: turn the held stick across the drag direction, lower it
  on the table just beyond the cube, pull it towards the goal until the cube's centre would be on the goal's
  centre, back off, put the stick down and park [``contact_xy``: where the stick comes down, ``drag_rel``: the
  drag's length].
- ``sweep {"obj": broom, "target": dustpan}``: turn the held broom so that its head faces the dustpan, lower
  the head on the table behind the dirt, push it into the pan, lift and park still holding the broom
  [``contact_xy``: where the head comes down, ``sweep_rel``: the stroke's length].
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from code_as_monitor.core.errors import SimError
from code_as_monitor.sim.motion import SLOW_SPEED

RLBENCH_SKILLS: dict[str, tuple[tuple[str, ...], str]] = {
    "put_in": (("obj", "target"), "gripper"),
    "screw": (("obj",), "gripper"),
    "turn": (("obj",), "gripper"),
    "drag": (("obj", "target", "goal"), "gripper"),
    "sweep": (("obj", "target"), "gripper"),
}
"""Skill -> (required args naming objects, end-effector kind)."""

PARK = (0.32, -0.33, 0.30)  # tip position out of the cameras' way, metres
CARRY_Z = 0.20  # grasp-point height for carrying, metres
PUT_CLEARANCE = 0.015  # metres between the item's bottom and the tray's floor at release
SCREW_STROKES = 3
SCREW_RATE = 1.5  # rad/s of a screwing stroke
TURN_RATE = 0.8  # rad/s of a tap turn
TOOL_SPEED = 0.10  # m/s of a drag or a sweep stroke
YAW_RANGE = (np.radians(-130.0), np.radians(160.0))
"""Tool yaws (radians) the Panda's last joint reaches with the tool pointing down (measured: -135 .. 170 degrees)."""
TOOL_CLEARANCE = 0.004  # metres between a held tool's lowest face and the table during a stroke


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _heading(v: np.ndarray) -> float:
    return float(np.arctan2(v[1], v[0]))


def _wrap(a: float) -> float:
    return float((a + np.pi) % (2 * np.pi) - np.pi)


class RLBenchSkills:
    """Skill generators; expects ``world``, ``task``, ``mover``, ``noise``, ``_aabb``, ``_lift``, ``_grip_open``,
    ``_grip_close``, ``_grasp`` and ``_judge`` (see :class:`~code_as_monitor.sim.policies.ScriptedPolicy`)."""

    world: Any
    task: Any
    mover: Any
    noise: Any

    # --- helpers ---------------------------------------------------------------------------------------
    def _held_body(self, obj: str, skill: str) -> int | None:
        """The body of ``obj`` if the gripper holds it, else None (the skill then plays on, holding nothing)."""
        held = self.world.robot.ee.holding
        return held if held is not None and self.world.name_of(held) == obj else None

    def _rigid_move(self, point: np.ndarray, yaw_change: float, dest: np.ndarray) -> tuple[np.ndarray, float]:
        """Tool tip and yaw that bring a point rigidly held by the tool (``point`` (3,), world, now) to ``dest``
        (3,) after turning the tool by ``yaw_change`` radians about the vertical."""
        v = _rot_z(yaw_change) @ (self.mover.tip - np.asarray(point, float))
        return np.asarray(dest, float) + v, self.mover.yaw + yaw_change

    def _park(self) -> Iterator[None]:
        yield from self._lift(CARRY_Z)  # type: ignore[attr-defined]
        yield from self.mover.move(PARK, pitch=0.0)

    # --- put_in ---------------------------------------------------------------------------------------
    def _put_in(self, obj: str, target: str) -> Iterator[None]:
        drop = np.asarray(self.task.drop_point(self.world, target), float)  # (3,) tray floor, open part's centre
        drop[:2] += self.noise.offset("place_xy")
        lo, _ = self._aabb(obj)  # type: ignore[attr-defined]
        below = float(self.mover.tip[2] - lo[2]) if self._held_body(obj, "put_in") is not None else 0.02
        rim = float(self.task.drawer_top(self.world, target))
        above = max(CARRY_Z, rim + below + 0.05)
        yield from self._lift(above)  # type: ignore[attr-defined]
        yield from self.mover.move([*drop[:2], above])
        yield from self.mover.move([*drop[:2], drop[2] + below + PUT_CLEARANCE], speed=SLOW_SPEED)
        yield from self.mover.wait(0.1)
        self._grip_open()  # type: ignore[attr-defined]
        yield from self.mover.wait(0.4)
        self._judge("put_in", obj=obj, target=target)  # type: ignore[attr-defined]
        yield from self.mover.move([*drop[:2], above], speed=SLOW_SPEED * 2)
        yield from self.mover.move(PARK, pitch=0.0)

    # --- screw ---------------------------------------------------------------------------------------
    def _screw(self, obj: str, turns: float = 1.0, part: str = "bulb") -> Iterator[None]:
        if not 0.0 < float(turns) <= 3.0:
            raise SimError(f"screw: turns must be in (0, 3], got {turns!r}")
        pitch = float(self.task.thread_pitch)
        stroke = 2 * np.pi * float(turns) / SCREW_STROKES
        y_start = self.mover.yaw
        for k in range(SCREW_STROKES):
            if k > 0:  # let go, turn back with the jaws open, grasp again where the bulb is now
                self._grip_open()  # type: ignore[attr-defined]
                yield from self.mover.wait(0.1)
                up = self.mover.tip + np.array([0.0, 0.0, 0.015])
                yield from self.mover.move(up, speed=SLOW_SPEED)
                centre = self.task.grasp_centre(self.world, obj, part)
                centre[:2] += self.noise.offset("grasp_xy")
                centre[2] += self.noise.normal("grasp_z")
                yield from self.mover.move([*centre[:2], up[2]], y_start)
                yield from self.mover.move(centre, speed=SLOW_SPEED)
                yield from self.mover.wait(0.1)
                self._grip_close()  # type: ignore[attr-defined]
                yield from self.mover.wait(0.1)
                self._judge("grasp", obj=obj, part=part)  # type: ignore[attr-defined]
            a = stroke * (1.0 + self.noise.normal("turn_rel"))
            down = self.mover.tip - np.array([0.0, 0.0, pitch * a / (2 * np.pi)])
            yield from self.mover.move(down, self.mover.yaw - a, speed=0.05, min_time=a / SCREW_RATE)
            yield from self.mover.wait(0.1)
        self._grip_open()  # type: ignore[attr-defined]
        yield from self.mover.wait(0.2)
        self._judge("screw", obj=obj, part=part)  # type: ignore[attr-defined]
        yield from self.mover.move(self.mover.tip + np.array([0.0, 0.0, 0.06]), speed=SLOW_SPEED * 2)
        yield from self._park()

    # --- turn ---------------------------------------------------------------------------------------
    def _turn(self, obj: str, part: str = "", angle: float = 90.0) -> Iterator[None]:
        # the part the policy believes it holds (a wrong target grasped turns that one, about its own hinge)
        part = getattr(self, "grasped_part", {}).get(obj, part) or part
        if part not in self.world.objects[obj].parts:
            raise SimError(f"turn: {obj!r} has no part {part!r}")
        if not 0.0 < float(angle) <= 100.0:
            raise SimError(f"turn: angle must be in (0, 100] degrees, got {angle!r}")
        hinge = self.world.pose(f"{obj}/{part}")[:3, 3]  # the handle link's frame is on its joint axis
        a = float(self.task.turn_sign(part)) * np.radians(float(angle)) * (1.0 + self.noise.normal("turn_rel"))
        tip0, y0 = self.mover.tip.copy(), self.mover.yaw
        n = max(1, round(abs(a) / TURN_RATE / self.world.dt))
        from code_as_monitor.sim.motion import min_jerk

        for k in range(1, n + 1):
            s = min_jerk(k / n)
            self.mover.tip = hinge + _rot_z(s * a) @ (tip0 - hinge)
            self.mover.tip[2] = tip0[2]
            self.mover.yaw = y0 + s * a
            self.world.robot.move_tip(self.mover.tip, self.mover.yaw, self.mover.pitch)
            yield
        yield from self.mover.wait(0.1)
        self._grip_open()  # type: ignore[attr-defined]
        yield from self.mover.wait(0.2)
        self._judge("turn", obj=obj, part=part)  # type: ignore[attr-defined]
        yield from self.mover.move(self.mover.tip + np.array([0.0, 0.0, 0.08]), speed=SLOW_SPEED * 2)
        yield from self.mover.move(PARK, pitch=0.0)

    # --- drag ---------------------------------------------------------------------------------------
    def _drag(self, obj: str, target: str, goal: str) -> Iterator[None]:
        w = self.world
        cube, dest = w.position(target), w.position(goal)
        d = dest[:2] - cube[:2]
        dist = float(np.linalg.norm(d))
        d = d / max(dist, 1e-9)
        T = w.pose(obj)
        axis = T[:3, 0].copy()
        axis[2] = 0.0
        axis /= max(float(np.linalg.norm(axis)), 1e-9)
        across = np.array([-d[1], d[0]])
        # which way along the stick: the choice that keeps the grasp point nearer the robot's base
        contact_x = float(self.task.stick_contact)  # the point of the stick (its local x) that meets the cube
        gap = float(self.task.drag_gap(w, target, obj, d))  # cube centre to stick centreline where the stick comes down
        c = cube[:2] - d * gap + self.noise.offset("contact_xy")
        best = None
        for sgn in (1.0, -1.0):
            turn = _wrap(_heading(sgn * across) - _heading(axis[:2]))
            point = T[:3, 3] + T[:3, 0] * contact_x
            tip, yaw = self._rigid_move(point, turn, np.array([*c, 0.0]))
            # the tool's yaw must stay inside the wrist's range; then the nearer grasp point
            score = float(np.linalg.norm(tip[:2])) + 0.05 * abs(turn) + 10.0 * (not YAW_RANGE[0] <= yaw <= YAW_RANGE[1])
            if best is None or score < best[0]:
                best = (score, tip, yaw, point)
        _, tip, yaw, point = best  # type: ignore[misc]
        lowest = float(self._aabb(obj)[0][2])  # type: ignore[attr-defined]
        tip[2] = self.mover.tip[2] - (lowest - TOOL_CLEARANCE)  # the stick's bottom just above the table
        length = (dist + 0.01) * (1.0 + self.noise.normal("drag_rel"))
        yield from self._lift(CARRY_Z)  # type: ignore[attr-defined]
        yield from self.mover.move([*tip[:2], CARRY_Z], yaw)
        yield from self.mover.move(tip, speed=SLOW_SPEED)
        end = tip + np.array([*(d * length), 0.0])
        yield from self.mover.move(end, speed=TOOL_SPEED)
        yield from self.mover.wait(0.2)
        self._judge("drag", obj=obj, target=target, goal=goal)  # type: ignore[attr-defined]
        yield from self.mover.move(end - np.array([*(d * 0.04), 0.0]), speed=SLOW_SPEED)  # off the cube
        self._grip_open()  # type: ignore[attr-defined]  (the stick drops a few millimetres to the table)
        yield from self.mover.wait(0.2)
        yield from self._park()

    # --- sweep ---------------------------------------------------------------------------------------
    def _sweep(self, obj: str, target: str) -> Iterator[None]:
        w, task = self.world, self.task
        dirt = np.array([w.position(n)[:2] for n in task.dirt_names])
        inside = np.asarray(task.pan_point(w, target), float)[:2]  # where the head's front should end, in the pan
        d = inside - dirt.mean(axis=0)
        d = d / max(float(np.linalg.norm(d)), 1e-9)
        back = float(np.min((dirt - inside) @ d))  # the dirt farthest behind, along d (negative)
        head = w.pose(f"{obj}/head")
        T = w.pose(obj)
        axis = T[:3, 0].copy()  # the broom's handle -> head direction
        turn = _wrap(_heading(d) - _heading(axis[:2]))
        half = float(task.head_half_depth)
        start = inside + d * (back - float(task.dirt_half) - half - 0.02) + self.noise.offset("contact_xy")
        tip, yaw = self._rigid_move(head[:3, 3], turn, np.array([*start, 0.0]))
        lowest = float(self._aabb(f"{obj}/head")[0][2])  # type: ignore[attr-defined]
        tip[2] = self.mover.tip[2] - (lowest - TOOL_CLEARANCE)
        stroke = float(np.dot(inside - start, d)) - half
        stroke *= 1.0 + self.noise.normal("sweep_rel")
        yield from self._lift(CARRY_Z)  # type: ignore[attr-defined]
        yield from self.mover.move([*tip[:2], CARRY_Z], yaw)
        yield from self.mover.move(tip, speed=SLOW_SPEED)
        yield from self.mover.move(tip + np.array([*(d * stroke), 0.0]), speed=TOOL_SPEED)
        yield from self.mover.wait(0.4)
        self._judge("sweep", obj=obj, target=target)  # type: ignore[attr-defined]
        yield from self.mover.move(self.mover.tip + np.array([0.0, 0.0, 0.08]), speed=SLOW_SPEED * 2)
        yield from self.mover.move(PARK, pitch=0.0)
