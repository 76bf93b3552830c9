"""The ``pour-tea`` disturbances: the pot turned in the grasp in transport ((a) forward, (b) sideways) and the
pour undone ((c)); see :mod:`code_as_monitor.sim.tasks.pour_tea` for what each one does and the events it logs."""

from __future__ import annotations

from typing import Any

import numpy as np

from code_as_monitor.sim.disturbances import Disturbance, PolicyWrapper
from code_as_monitor.sim.motion import min_jerk
from code_as_monitor.sim.triggered import Triggered

TURN_RATE = np.radians(120.0)  # rad/s: (a) and (b) turn the pot over half a second, not at once
UNPOUR_TILT_DEG = 40.0  # (c) fires once the pot is tilted this far: the 35-degree spout slopes down, tea begins to run
UNPOUR_S = 0.5  # (c) the wrist returns to level over this many seconds


def _tilt_deg(world: Any) -> float:
    """The pot's tilt: angle between its up axis and world z, degrees."""
    return float(np.degrees(np.arccos(np.clip(world.pose("teapot")[2, 2], -1.0, 1.0))))


class Carrying:
    """Condition: the pot is held level (within 10 degrees) and has come 3 cm closer (horizontally) to the cup
    than when it was first held level."""

    def __init__(self) -> None:
        self.d0: float | None = None

    def __call__(self, world: Any) -> bool:
        if world.robot.ee.holding != world.body_of("teapot") or _tilt_deg(world) > 10.0:
            return False
        d = float(np.linalg.norm(world.position("teapot")[:2] - world.position("teacup")[:2]))
        if self.d0 is None:
            self.d0 = d
        return d < self.d0 - 0.03


def _tool_rotation(world: Any) -> np.ndarray:
    import pybullet as pb

    orn = pb.getBasePositionAndOrientation(world.robot.ee.body, physicsClientId=world.client)[1]
    return np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))


def _rot(axis: int, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


class TurnInGrasp:
    """Tick hook: the held pot turns in the grasp about the tool's ``axis`` (0 x, 1 y, 2 z) through the grasp
    point, at ``rate`` rad/s until it has turned ``angle`` radians (signed), as a perturbed end-effector joint
    would. The grasp constraint's frame is turned a little each tick, so the solver moves the pot and the tea in
    it moves with it (a pose reset would throw the tea out). The turn stops early when the policy is halted
    (the controller then holds the measured pose, which arrests the perturbed joint); at the end the grasp is
    re-made at the pose reached (the gripper's bookkeeping for save/restore)."""

    def __init__(self, world: Any, axis: int, angle: float, rate: float, halted: Any) -> None:
        import pybullet as pb

        ee = world.robot.ee
        att = ee.attachment()
        if att is None:
            raise ValueError("TurnInGrasp: nothing is held")
        self.body, rel_pos, rel_orn, self.link = att
        self.rel = (tuple(rel_pos), tuple(rel_orn))
        self.cid = ee._constraint
        self.axis, self.angle = int(axis), float(angle)
        self.n = max(1, round(abs(self.angle) / rate / world.dt))
        self.k = 0
        self.halted = halted  # () -> bool: the policy has been halted since the turn began
        self.tip = [0.0, 0.0, float(ee.tip_length)]  # the grasp point in the tool frame
        self._pb = pb

    def _child_frame(self, a: float) -> tuple:
        """The constraint's child frame that holds the pot turned by ``a`` radians from its grasp pose."""
        pb = self._pb
        axis_v = [0.0, 0.0, 0.0]
        axis_v[self.axis] = 1.0
        q = pb.getQuaternionFromAxisAngle(axis_v, a)
        rel_pos = (np.asarray(self.rel[0]) - self.tip).tolist()
        turned_pos, turned_orn = pb.multiplyTransforms([0, 0, 0], q, rel_pos, self.rel[1])
        turned_pos = (np.asarray(turned_pos) + self.tip).tolist()
        ipos, iorn = pb.invertTransform(turned_pos, turned_orn)
        return pb.multiplyTransforms(ipos, iorn, *self.rel)  # rel' ^ -1 * rel

    def __call__(self, world: Any) -> None:
        ee, pb, c = world.robot.ee, self._pb, world.client
        if ee.holding != self.body or ee._constraint != self.cid:  # let go, or re-grasped: nothing to turn
            world.tick_hooks.remove(self)
            return
        if not self.halted() and self.k < self.n:
            self.k += 1
            pos, orn = self._child_frame(self.angle * self.k / self.n)
            pb.changeConstraint(self.cid, jointChildPivot=pos, jointChildFrameOrientation=orn,
                                maxForce=ee.hold_force, physicsClientId=c)
            return
        world.tick_hooks.remove(self)  # re-grasp at the pose reached, so the constraint's frames are plain again
        tpos, torn = pb.getBasePositionAndOrientation(ee.body, physicsClientId=c)
        opos, oorn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        ipos, iorn = pb.invertTransform(tpos, torn)
        rpos, rorn = pb.multiplyTransforms(ipos, iorn, opos, oorn)
        ee.detach()
        ee.attach(self.body, rpos, rorn, self.link)


class TurnTrigger(Triggered):
    """A :class:`~code_as_monitor.sim.triggered.Triggered` turn in the grasp that knows when the policy is
    halted (it wraps the policy), which arrests the turn (:class:`TurnInGrasp`)."""

    def __init__(self, name: str, when: Any, axis: int, angle: tuple[float, float], spout_down: bool,
                 seed: Any = 0) -> None:
        super().__init__(name, when, _tilt_in_grasp(axis, angle, self._halted_since, spout_down), seed)
        self.halts = 0
        self._halts_at_fire = 0

    def _halted_since(self, start: bool = False) -> bool:
        if start:
            self._halts_at_fire = self.halts
        return self.halts > self._halts_at_fire

    def wrap(self, policy: Any) -> Any:
        return _HaltCounter(policy, self)


class _HaltCounter(PolicyWrapper):
    """Forwards to the policy; counts its halts on ``owner.halts``."""

    def __init__(self, inner: Any, owner: TurnTrigger) -> None:
        super().__init__(inner)
        self.owner = owner

    def halt(self) -> None:
        self.owner.halts += 1
        self.inner.halt()


def _tilt_in_grasp(axis: int, angle: tuple[float, float], halted: Any, spout_down: bool = False) -> Any:
    """Effect: start turning the held pot about the tool's ``axis`` by an angle uniform in ``angle`` radians
    (:class:`TurnInGrasp`, at ``TURN_RATE``); the sign is the one that tips the spout down when ``spout_down``,
    else random. Logs ``grasp_perturbed`` (``angle``: the turn planned, ``axis``)."""

    def effect(world: Any, rng: np.random.Generator) -> None:
        a = float(rng.uniform(*angle))
        if spout_down:
            R_tool = _tool_rotation(world)
            spout = R_tool.T @ world.pose("teapot")[:3, 0]  # the pot's +x (to the spout) in the tool frame
            z = [float((R_tool @ _rot(axis, s * a) @ spout)[2]) for s in (1.0, -1.0)]
            a = a if z[0] < z[1] else -a
        else:
            a *= float(rng.choice([-1.0, 1.0]))
        halted(start=True)
        world.tick_hooks.append(TurnInGrasp(world, axis, a, TURN_RATE, halted))
        world.events.log(world.t, "grasp_perturbed", "teapot", angle=a, axis=axis)

    return effect


class UndoPour(Disturbance):
    """(c): once the held pot is tilted past ``UNPOUR_TILT_DEG`` (the tea has begun to run) the pour motion is
    aborted and undone: the policy's current action stops (as a halt would) and the wrist returns to the pose,
    at the same grasp point and yaw, that holds the pot level (give or take 3 degrees). Logs ``pour_undone``.

    It wraps the policy (to stop the running action) and installs a tick hook (the trigger)."""

    name = "unpour"

    def __init__(self, seed: Any = 0) -> None:
        super().__init__(seed)
        self.policy: Any = None
        self.fired_at: float | None = None

    def wrap(self, policy: Any) -> Any:
        self.policy = policy
        return policy

    def install(self, world: Any) -> None:
        world.tick_hooks.append(self._on_tick)

    def _on_tick(self, world: Any) -> None:
        if self.fired_at is not None or world.robot.ee.holding != world.body_of("teapot"):
            return
        if _tilt_deg(world) < UNPOUR_TILT_DEG:
            return
        from code_as_monitor.sim.pour_skills import level_pitch

        self.fired_at = world.t
        robot = world.robot
        up = robot.ee_pose()[:3, :3].T @ world.pose("teapot")[:3, 2]  # the pot's up axis in the flange frame
        pitch = level_pitch(up) + float(self.rng.uniform(-0.05, 0.05))
        if self.policy is not None:
            halted_at = world.halted_at
            self.policy.halt()
            world.halted_at = halted_at  # not a monitor's halt
        q0 = np.array(robot.joints())
        q1 = np.array(robot.ik(robot.tip(), robot.yaw(), pitch))
        n = max(1, round(UNPOUR_S / world.dt))
        starts = len(world.events.of_kind("action_start"))
        k = 0

        def back_to_level(w: Any) -> None:  # a smooth return; ends early when the policy starts a new action
            nonlocal k
            k += 1
            if len(w.events.of_kind("action_start")) > starts or k > n:
                w.tick_hooks.remove(back_to_level)
                return
            w.robot.command(list(q0 + min_jerk(k / n) * (q1 - q0)))

        world.tick_hooks.append(back_to_level)
        world.events.log(world.t, "pour_undone", "teapot", pitch=pitch)
