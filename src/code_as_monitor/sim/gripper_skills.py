"""Scripted gripper skills (oracle, open loop): grasp, reorient, insert.

Mixed into :class:`~code_as_monitor.sim.policies.ScriptedPolicy`. Like the suction skills, each one
computes its targets from the ground-truth poses when it starts and then plays smooth moves without
looking again: a pen moved under the fingers is not followed, a dropped pen is not noticed.

Skills (``Action.skill``, ``Action.args``):

- ``grasp {"obj": name, "part": part optional}``: open the fingers, move above the object with the
  closing axis across its long (local x) axis (or across ``task.grasp_axis(world, obj, part)`` when the
  task defines it), descend until the grasp point is at the part's centre, close, lift to carry height
  (no lift when the grasp fixed a link of a fixed-base articulated body, such as a drawer's handle).
- ``reorient {"obj": name, "axis": "vertical"}``: lift, turn (yaw) so that the tool will point away
  from the robot base, then tilt (pitch) so the held object's long axis points straight down
  (its ``tip`` end first).
- ``insert {"obj": name, "target": name}``: carry the held object's lowest end above the target's
  opening (``rim`` part), descend until that end is ``INSERT_DEPTH`` above the target's floor,
  open (a ``released`` event, judged at rest by :mod:`code_as_monitor.sim.placement`), retreat and park.
- ``stow {"obj": name, "target": name}``: the same motion into the target's ``slot`` part (a book held
  upright, lowered into a bookshelf slot until its lower end is ``INSERT_DEPTH`` above the slot floor).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from code_as_monitor.core.errors import SimError
from code_as_monitor.sim.motion import SLOW_SPEED, wrap_angle

GRIPPER_SKILLS: dict[str, tuple[tuple[str, ...], str]] = {
    "grasp": (("obj",), "gripper"),
    "reorient": (("obj",), "gripper"),
    "insert": (("obj", "target"), "gripper"),
    "stow": (("obj", "target"), "gripper"),
}
"""Skill -> (required args naming objects, end-effector kind)."""

GRIP_CARRY_Z = 0.22  # grasp-point height for carrying a held object, metres
GRIP_APPROACH = 0.06  # clearance above a part before the slow descent, metres
INSERT_CLEARANCE = 0.04  # lowest end above the rim before descending, metres
INSERT_DEPTH = 0.012  # lowest end above the holder floor at release, metres
GRIP_PARK = (0.32, -0.33, 0.30)


def tilted_yaw(tip: np.ndarray, pitch: float) -> float:
    """Tool yaw for a tilt ``pitch`` at ``tip`` that keeps the Panda's wrist inside its joint limits.

    A tool tilted by ``pitch`` about its x axis points along Rz(yaw) (0, sin p, 0) horizontally. Pointing
    it straight away from the base drives the wrist (joint 6) past its limit near pitch pi/2; pointing
    it tangentially (90 degrees from "outward", the side set by the sign of the pitch) keeps a smooth
    IK solution over the workspace (measured: under 2 mm tracking error, scripts in benchmarks/).
    """
    out = np.asarray(tip[:2], float) / max(float(np.linalg.norm(tip[:2])), 1e-6)
    ang = float(np.arctan2(out[1], out[0])) + (np.pi / 2 if pitch >= 0 else -np.pi / 2)
    d = np.array([np.cos(ang), np.sin(ang)])  # wanted horizontal pointing direction of the tool
    return float(np.arctan2(-d[0], d[1])) if pitch >= 0 else float(np.arctan2(d[0], -d[1]))


class GripperSkills:
    """Gripper skill generators; expects ``world``, ``task``, ``mover``, ``_aabb`` and ``_lift``."""

    world: Any
    task: Any
    mover: Any
    noise: Any
    grasped_part: dict[str, str]

    # --- helpers -------------------------------------------------------------------------------------
    def _axis(self, name: str) -> np.ndarray:
        """(3,) world direction of object ``name``'s long (local x) axis."""
        return self.world.pose(name)[:3, 0].copy()

    def _grip_open(self) -> str:
        """Open the fingers; the name of what they let go (``""`` if nothing)."""
        held = self.world.robot.ee.open()
        name = self.world.name_of(held)
        self.world.events.log(self.world.t, "gripper_open", name)
        return name

    def _grip_close(self) -> None:
        got = self.world.robot.ee.close(self.world.graspable)
        self.world.events.log(self.world.t, "gripper_close", self.world.name_of(None if got is None else got[0]))

    # --- skills ----------------------------------------------------------------------------------------
    def _grasp(self, obj: str, part: str = "") -> Iterator[None]:
        if part and part not in self.world.objects[obj].parts:
            raise SimError(f"grasp: {obj!r} has no part {part!r}")
        intended = part
        confusable = getattr(self.task, "confusable", None)  # a part alike enough to be taken for this one
        if confusable is not None and confusable(obj, part) and self.noise.chance("wrong_target"):
            part = confusable(obj, part)
        self.grasped_part[obj] = part
        name = f"{obj}/{part}" if part else obj
        grasp_centre = getattr(self.task, "grasp_centre", None)
        if grasp_centre is not None:
            centre = np.asarray(grasp_centre(self.world, obj, part), float)
        else:
            lo, hi = self._aabb(name)  # type: ignore[attr-defined]
            centre = (lo + hi) / 2
        hi = self._aabb(name)[1]  # type: ignore[attr-defined]
        # a task may name the direction to close across (a drawer's handle bar); else the object's long axis
        grasp_axis = getattr(self.task, "grasp_axis", None)
        u = self._axis(obj) if grasp_axis is None else np.asarray(grasp_axis(self.world, obj, part), float)
        # the tool's y axis along the object's long axis; the jaw is symmetric, so either way round
        # (the one nearest the current yaw, unless the last wrist joint would end near a limit there)
        yaw = float(np.arctan2(u[0], -u[1]))
        yaw = self.mover.yaw + wrap_angle(2 * (yaw - self.mover.yaw)) / 2
        grasp_yaw = getattr(self.task, "grasp_yaw", None)  # a task may need one of the two exactly (a bulb to turn)
        exact = None if grasp_yaw is None else grasp_yaw(self.world, obj, part, self.mover.yaw)
        if exact is not None:
            yaw = float(exact)
        else:
            yaw = self.mover.roomy_yaw([*centre[:2], max(GRIP_CARRY_Z, hi[2] + GRIP_APPROACH)], yaw, np.pi)
        centre[:2] += self.noise.offset("grasp_xy")  # a learned policy's imprecision (exact by default)
        centre[2] += self.noise.normal("grasp_z")
        yaw += self.noise.normal("grasp_yaw")
        if self.world.robot.ee.active:
            self._grip_open()
        top = max(GRIP_CARRY_Z, hi[2] + GRIP_APPROACH)
        yield from self._lift(top)  # type: ignore[attr-defined]
        yield from self.mover.move([*centre[:2], top], yaw, pitch=0.0)
        yield from self.mover.move([*centre[:2], centre[2] + GRIP_APPROACH * 0.5], speed=SLOW_SPEED * 2)
        yield from self.mover.move(centre, speed=SLOW_SPEED)
        yield from self.mover.wait(0.1)
        self._grip_close()
        yield from self.mover.wait(0.1)
        self._judge("grasp", obj=obj, part=part, intended=intended)  # type: ignore[attr-defined]
        att = self.world.robot.ee.attachment()
        if att is not None and att[3] >= 0:  # a link of a fixed-base articulated body (a handle): no lift
            return
        yield from self.mover.move([*centre[:2], top], speed=SLOW_SPEED * 2)

    def _reorient(self, obj: str, axis: str = "vertical") -> Iterator[None]:
        if axis != "vertical":
            raise SimError(f"reorient: only axis 'vertical' is supported, got {axis!r}")
        T_tool = self.world.robot.grasp_pose()
        a = T_tool[:3, :3].T @ self._axis(obj)  # the object's axis in the tool frame
        pitch = float(np.arctan2(a[1], a[2]))  # tilts the axis to world -z (see robot.down_quat)
        yaw = tilted_yaw(self.mover.tip, pitch)
        yield from self._lift(GRIP_CARRY_Z)  # type: ignore[attr-defined]
        yield from self.mover.move([*self.mover.tip[:2], GRIP_CARRY_Z], yaw)
        yield from self.mover.move(self.mover.tip, pitch=pitch, speed=SLOW_SPEED)

    def _insert(self, obj: str, target: str) -> Iterator[None]:
        yield from self._lower_into(obj, target, "rim", "insert")

    def _stow(self, obj: str, target: str) -> Iterator[None]:
        yield from self._lower_into(obj, target, "slot", "stow")

    def _lower_into(self, obj: str, target: str, part: str, skill: str) -> Iterator[None]:
        """Carry the held ``obj``'s lowest end above ``target``'s opening (its ``part``), lower it in, release."""
        rim = f"{target}/{part}"
        if part not in self.world.objects[target].parts:
            raise SimError(f"{skill}: {target!r} has no opening (part {part!r})")
        grip = self.world.robot.tip()
        end = self.task.lowest_point(self.world, obj)  # the end that goes in first
        d = end - grip
        goal = self.world.position(target)[:2]
        rim_top = float(self._aabb(rim)[1][2])  # type: ignore[attr-defined]
        floor = float(self.world.position(target)[2]) + self.task.holder_floor
        xy = goal - d[:2]
        above = rim_top + INSERT_CLEARANCE - d[2]
        yield from self._lift(max(GRIP_CARRY_Z, above))  # type: ignore[attr-defined]
        yield from self.mover.move([*xy, max(GRIP_CARRY_Z, above)])
        yield from self.mover.move([*xy, above], speed=SLOW_SPEED * 2)
        yield from self.mover.move([*xy, floor + INSERT_DEPTH - d[2]], speed=SLOW_SPEED)
        yield from self.mover.wait(0.1)
        let_go = self._grip_open()
        if let_go:  # judged once it rests (sim.placement): ``placed`` or ``misplaced``
            self.world.events.log(self.world.t, "released", let_go, target=target, skill=skill)
        yield from self.mover.wait(0.2)
        yield from self.mover.move([*xy, max(GRIP_CARRY_Z, above) + 0.05], speed=SLOW_SPEED * 2)
        yield from self.mover.move(GRIP_PARK, pitch=0.0)
