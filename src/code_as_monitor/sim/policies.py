"""Scripted open-loop demonstrators (CLIPort-oracle style) behind :class:`core.policy.Policy`.

The policy computes its targets from the *current* ground-truth object poses when an action starts
(and, for the looping skills, at the start of each stroke/adjustment), then plays smooth waypoint
motions one control tick per :meth:`ScriptedPolicy.step`. It never reacts to disturbances during
an action: a dropped block is not re-picked, a toppled tower is not noticed.

Driving it from outside (the agent)::

    policy.start(Action("pick", {"obj": "green_block"}))
    while not policy.done:
        policy.step()                 # one control tick; the world advances with it
        if world.frame_due():
            obs = world.observe()     # render + monitor
            if violated: policy.halt()  # the arm stops at once; suction state is kept

``step()`` after ``done`` holds the arm and still advances the world one tick.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import SimError
from code_as_monitor.sim.drawer_skills import DRAWER_SKILLS, DrawerSkills
from code_as_monitor.sim.gripper_skills import GRIPPER_SKILLS, GripperSkills
from code_as_monitor.sim.motion import PUSH_SPEED, SLOW_SPEED, Mover, wrap_angle
from code_as_monitor.sim.pour_skills import POUR_SKILLS, PourSkills
from code_as_monitor.sim.rlbench_skills import RLBENCH_SKILLS, RLBenchSkills
from code_as_monitor.sim.world import World

PARK = (0.32, -0.33, 0.30)  # tip position out of the cameras' way after a placement, metres
CARRY_Z = 0.16  # tip height for carrying above the scene, metres
APPROACH = 0.06  # clearance above a surface before the slow descent, metres
FREE_CLEARANCE = 0.10  # metres from every other object for a spot of free table
WORKSPACE = ((0.32, 0.68), (-0.28, 0.28))  # (x range, y range) of table the suction tasks use, metres
CONTACT_SEARCH = 0.02  # a pick descends at most this far below the object's top looking for contact, metres
PUSH_Z = 0.01  # spatula tip height during a stroke, metres
SKILLS: dict[str, tuple[tuple[str, ...], str]] = {
    "pick": (("obj",), "suction"),
    "place_on": (("obj", "target"), "suction"),
    "push_into_region": (("region",), "spatula"),
    "close_shape": (("rope", "shape"), "suction"),
    **GRIPPER_SKILLS,
    **POUR_SKILLS,
    **DRAWER_SKILLS,
    **RLBENCH_SKILLS,
}


class ScriptedPolicy(GripperSkills, PourSkills, DrawerSkills, RLBenchSkills):
    """Oracle pick-and-place / push / rope-adjustment policy for one world and task.

    ``noise``: the task's action noise (``task.action_noise(seed)``; the RLBench-style tasks' learned-policy
    analogue, :mod:`code_as_monitor.sim.action_noise`), exact for every other task. ``grasped_part``: object ->
    the part the last grasp aimed at (a wrong target when the noise picked the other one).
    """

    def __init__(self, world: World, task: Any) -> None:
        self.world = world
        self.task = task
        self.mover = Mover(world)
        self._gen: Iterator[None] | None = None
        self.action: Action | None = None
        self.halted = False
        self.noise = task.action_noise(world.seed)
        self.grasped_part: dict[str, str] = {}

    # --- Policy protocol ----------------------------------------------------------------------------
    def start(self, action: Action) -> None:
        """Begin ``action``; SimError naming an unknown skill, a missing argument or an unknown object."""
        self.validate(action)
        self.action = action
        self.halted = False
        self.world.halted_at = None
        self.mover.sync()
        self._gen = getattr(self, "_" + action.skill)(**action.args)
        self.world.events.log(self.world.t, "action_start", action.args.get("obj", ""), skill=action.skill,
                              args=action.args)

    def step(self) -> None:
        """Advance one control tick (the world ticks too)."""
        if self._gen is not None:
            try:
                next(self._gen)
            except StopIteration:
                self._gen = None
                a = self.action
                assert a is not None
                self.world.events.log(self.world.t, "action_done", a.args.get("obj", ""), skill=a.skill)
                self.world.robot.hold()
        else:
            self.world.robot.hold()
        self.world.tick()

    def halt(self) -> None:
        """Stop now: the arm holds its measured pose, suction state is kept."""
        if self._gen is not None:
            self._gen.close()
            self._gen = None
            a = self.action
            self.world.events.log(self.world.t, "action_halted", a.args.get("obj", "") if a else "",
                                  skill=a.skill if a else "")
        self.halted = True
        self.world.halted_at = self.world.t
        self.world.robot.command(list(self.world.robot.joints()))
        self.mover.sync()

    @property
    def done(self) -> bool:
        return self._gen is None

    def _judge(self, skill: str, **args: Any) -> None:
        """Ask the task whether ``skill`` did what it should (``task.judge(world, skill, args) -> what | None``) and
        log the episode's first failure as a ``policy_failure`` event (``what``, ``skill``, ``objects``: the objects
        the skill acted on): later ones are its consequences. Tasks without ``judge`` log nothing."""
        judge = getattr(self.task, "judge", None)
        if judge is None:
            return
        what = judge(self.world, skill, args)
        if what and not self.world.events.of_kind("policy_failure"):
            objects = [args[k] for k in ("obj", "target", "goal") if isinstance(args.get(k), str) and args[k]]
            self.world.events.log(self.world.t, "policy_failure", args.get("obj", ""), what=what, skill=skill,
                                  objects=objects)

    @property
    def skills(self) -> tuple[str, ...]:
        """The skills this robot can execute: those of its end-effector (what the planner is offered)."""
        ee = self.world.robot.ee.kind
        return tuple(name for name, (_, kind) in SKILLS.items() if kind == ee)

    # --- validation -----------------------------------------------------------------------------------------
    def validate(self, action: Action) -> None:
        if action.skill not in SKILLS:
            raise SimError(f"unknown skill {action.skill!r}; known: {', '.join(SKILLS)}")
        required, ee = SKILLS[action.skill]
        missing = [k for k in required if k not in action.args]
        if missing:
            raise SimError(f"skill {action.skill!r} needs argument(s) {', '.join(missing)}; got {action.args}")
        if self.world.robot.ee.kind != ee:
            raise SimError(f"skill {action.skill!r} needs the {ee} end-effector; this task has "
                           f"{self.world.robot.ee.kind}")
        for k in required:
            name = action.args[k]
            if k == "target" and name == "table":
                continue
            if not isinstance(name, str) or not self._known(name):
                raise SimError(f"skill {action.skill!r}: unknown object {name!r} for {k!r}; known: "
                               f"{', '.join(sorted(self.world.objects))}")
        xy = action.args.get("xy")
        if xy is not None and (not isinstance(xy, (list, tuple)) or len(xy) != 2):
            raise SimError(f"place_on: xy must be [x, y] metres, got {xy!r}")

    def _known(self, name: str) -> bool:
        obj, _, part = name.partition("/")
        return obj in self.world.objects and (not part or part in self.world.objects[obj].parts)

    # --- geometry helpers -------------------------------------------------------------------------------------
    def _aabb(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds (min (3,), max (3,)) of an object or part, world metres."""
        import pybullet as pb

        c = self.world.client
        obj, _, part = name.partition("/")
        if part:
            b, link = self.world.objects[obj].parts[part]
            lo, hi = pb.getAABB(b, link, physicsClientId=c)
            return np.array(lo), np.array(hi)
        so = self.world.objects[obj]
        boxes = []
        for b in so.bodies:
            boxes.append(pb.getAABB(b, -1, physicsClientId=c))
            for j in range(pb.getNumJoints(b, physicsClientId=c)):
                boxes.append(pb.getAABB(b, j, physicsClientId=c))
        return np.min([x[0] for x in boxes], 0), np.max([x[1] for x in boxes], 0)

    def _yaw_of(self, name: str) -> float:
        R = self.world.pose(name)[:3, :3]
        return float(np.arctan2(R[1, 0], R[0, 0]))

    def place_xy(self, action: Action) -> np.ndarray:
        """The (2,) place position a ``place_on`` action aims at (its ``xy`` or the target's centre)."""
        if action.args.get("xy") is not None:
            return np.asarray(action.args["xy"], dtype=float)
        target = action.args["target"]
        if target == "table":
            return self.free_table_xy(str(action.args.get("obj", "")))
        return self.world.position(target)[:2]

    def free_table_xy(self, obj: str, clearance: float = FREE_CLEARANCE) -> np.ndarray:
        """(2,) the table spot nearest the tip's position that is at least ``clearance`` metres from every other
        object (``obj`` and the table excepted) and inside ``WORKSPACE``: where "put it down on the table" goes."""
        tip = self.world.robot.tip()[:2]
        others = [self.world.position(n)[:2] for n in self.world.objects if n not in (obj, "table")]
        (x0, x1), (y0, y1) = WORKSPACE
        for r in np.arange(0.0, 0.45, 0.03):
            for a in np.linspace(0.0, 2 * np.pi, 24, endpoint=False) if r > 0 else (0.0,):
                p = tip + r * np.array([np.cos(a), np.sin(a)])
                if x0 <= p[0] <= x1 and y0 <= p[1] <= y1 and all(np.linalg.norm(p - q) >= clearance for q in others):
                    return p
        return np.clip(tip, [x0, y0], [x1, y1])

    def _lift(self, z: float = CARRY_Z) -> Iterator[None]:
        if self.mover.tip[2] < z - 1e-3:
            yield from self.mover.move([*self.mover.tip[:2], z], speed=SLOW_SPEED * 2)

    def _suction_on(self) -> None:
        ee = self.world.robot.ee
        held = ee.activate(self.world.graspable)  # type: ignore[attr-defined]
        self.world.events.log(self.world.t, "suction_on", self.world.name_of(held))

    def _suction_off(self) -> None:
        held = self.world.robot.ee.release()  # type: ignore[attr-defined]
        self.world.events.log(self.world.t, "suction_off", self.world.name_of(held))

    # --- skills -----------------------------------------------------------------------------------------------
    def _pick(self, obj: str, lift: float = CARRY_Z) -> Iterator[None]:
        hi = self._aabb(obj)[1]
        xy = self.world.position(obj)[:2]
        # suction is symmetric: align the tool's yaw with the object's (mod 90 degrees) nearest the current yaw
        yaw = self.mover.yaw + wrap_angle(4 * (self._yaw_of(obj) - self.mover.yaw)) / 4
        yaw = self.mover.roomy_yaw([*xy, max(lift, hi[2] + APPROACH)], yaw, np.pi / 2)
        yield from self._lift(max(lift, hi[2] + APPROACH))
        yield from self.mover.move([*xy, max(lift, hi[2] + APPROACH)], yaw)
        yield from self.mover.move([*xy, hi[2] + APPROACH * 0.5], speed=SLOW_SPEED * 2)
        yield from self.mover.move([*xy, hi[2] + 0.002], speed=SLOW_SPEED)
        yield from self._descend_to_contact(xy, hi[2])
        yield from self.mover.wait(0.1)
        self._suction_on()
        yield from self.mover.move([*xy, max(lift, hi[2] + APPROACH)], speed=SLOW_SPEED * 2)

    def _descend_to_contact(self, xy: np.ndarray, top: float) -> Iterator[None]:
        """Guarded descent: go on down in 3 mm steps (at most ``CONTACT_SEARCH`` below ``top``) until the cup
        touches something graspable. The arm's inverse kinematics is not exact everywhere in the workspace:
        close to the base the tip stops up to 1 cm above the commanded height, beyond the cup's contact
        tolerance, and a suction primitive moves down until contact rather than to a fixed height."""
        ee = self.world.robot.ee
        touching = getattr(ee, "touching", None)
        if touching is None:
            return
        z = self.mover.tip[2]
        while touching(self.world.graspable) is None and z > top - CONTACT_SEARCH:
            z -= 0.003
            yield from self.mover.move([*xy, z], speed=SLOW_SPEED, min_time=0.05)

    def _place_on(self, obj: str, target: str, xy: list[float] | None = None) -> Iterator[None]:
        dest = self.place_xy(Action("place_on", {"obj": obj, "target": target, "xy": xy}))
        top = 0.0 if target == "table" else float(self._aabb(target)[1][2])
        ee = self.world.robot.ee
        held = ee.holding
        tip = self.world.robot.tip()
        # distance from the tip down to the held object's bottom (nominal block if nothing is held)
        drop = float(tip[2] - self._aabb(self.world.name_of(held))[0][2]) if held is not None else 0.04
        yaw = self.mover.yaw
        if held is not None and target != "table":
            yaw = self.mover.yaw + wrap_angle(4 * (self._yaw_of(target) - self._yaw_of(self.world.name_of(held)))) / 4
        carry = max(CARRY_Z, top + drop + APPROACH)
        if held is not None:
            yaw = self.mover.roomy_yaw([*dest, carry], yaw, np.pi / 2)
        yield from self._lift(carry)
        yield from self.mover.move([*dest, carry], yaw)
        yield from self.mover.move([*dest, top + drop + 0.02], speed=SLOW_SPEED * 2)
        yield from self.mover.move([*dest, top + drop + 0.004], speed=SLOW_SPEED)
        yield from self.mover.wait(0.1)
        self._suction_off()
        yield from self.mover.wait(0.1)
        yield from self.mover.move([*dest, carry], speed=SLOW_SPEED * 2)
        yield from self.mover.move(PARK)  # retreat so the top view sees the result

    def _push_into_region(self, region: str) -> Iterator[None]:
        task = self.task
        center = task.region_center(self.world, region)
        while True:
            outside = [n for n in task.region_objects(region)
                       if not task.region_contains(self.world, region, self.world.position(n)[:2])]
            if not outside:
                return
            pts = np.array([self.world.position(n)[:2] for n in outside])
            far = pts[int(np.argmax(np.linalg.norm(pts - center, axis=1)))]
            d = center - far
            d = d / max(np.linalg.norm(d), 1e-9)
            # stop once the pushed block is a few cm past the region's entry, so the pile stays inside
            entry = task.region_entry(self.world, region, far, d)
            start, end = far - d * 0.035, entry + d * 0.03
            yaw = float(np.arctan2(d[1], d[0]))
            yield from self._lift(0.08)
            yield from self.mover.move([*start, 0.08], yaw)
            yield from self.mover.move([*start, PUSH_Z], speed=SLOW_SPEED * 2)
            yield from self.mover.move([*end, PUSH_Z], speed=PUSH_SPEED)
            yield from self.mover.move([*end, 0.08], speed=SLOW_SPEED * 2)

    def _close_shape(self, rope: str, shape: str) -> Iterator[None]:
        task = self.task
        while True:  # keeps adjusting forever: only a halt stops it
            beads = task.rope_parts(rope)
            targets = task.rope_targets(self.world, rope, shape)
            pos = np.array([self.world.position(f"{rope}/{b}")[:2] for b in beads])
            err = np.linalg.norm(pos - targets, axis=1)
            i = int(np.argmax(err))
            lo, hi = self._aabb(f"{rope}/{beads[i]}")
            yield from self._pick(f"{rope}/{beads[i]}", lift=0.05)
            yield from self.mover.move([*targets[i], 0.05])
            yield from self.mover.move([*targets[i], float(hi[2] - lo[2]) + 0.003], speed=SLOW_SPEED)
            self._suction_off()
            yield from self.mover.wait(0.05)
            yield from self.mover.move([*targets[i], 0.05], speed=SLOW_SPEED * 2)
