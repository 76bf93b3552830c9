"""One-shot, state-triggered disturbances for the gripper tasks (slot-pen, stow-book, ...).

The paper's OmniGibson disturbances happen at a *moment of the task* (while grasping, in transport,
during insertion, after placement), so each one here is a :class:`Triggered` disturbance: a tick
hook evaluates ``when(world)`` every control tick and, the first time it is true, applies an effect
and logs an event. Effects:

- :func:`slide` moves an object (its base) by an offset and a yaw over ``duration`` seconds, as a
  person would push it (event ``object_moved``);
- :func:`drop_held` makes the gripper lose its object; the fingers stay closed (event ``drop``);
- :func:`turn_in_grasp` rotates the held object inside the grasp about a tool axis, as a perturbed
  end-effector joint would (event ``grasp_perturbed``);
- :func:`lay_flat` knocks a released object over onto the table (event ``object_knocked``).

They compose with the other disturbances through :func:`~code_as_monitor.sim.disturbances.apply_disturbances`
(they only install tick hooks; none wraps the policy). All randomness comes from the disturbance's own
``rng``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from code_as_monitor.sim.disturbances import Disturbance

Effect = Callable[[Any, np.random.Generator], None]
Condition = Callable[[Any], bool]


class Triggered(Disturbance):
    """Applies ``effect(world, rng)`` once, the first tick ``when(world)`` holds.

    Attributes:
        name: short label (for events and reports).
        fired_at: sim time it fired, or None.
    """

    def __init__(self, name: str, when: Condition, effect: Effect, seed: Any = 0) -> None:
        super().__init__(seed)
        self.name = name
        self.when = when
        self.effect = effect
        self.fired_at: float | None = None

    def install(self, world: Any) -> None:
        world.tick_hooks.append(self._on_tick)

    def _on_tick(self, world: Any) -> None:
        if self.fired_at is None and not self.paused(world) and self.when(world):
            self.fired_at = world.t
            self.effect(world, self.rng)


class _Slide:
    """Tick hook that moves a body from its current pose by ``offset`` (3,) and ``dyaw`` over ``n`` ticks."""

    def __init__(self, world: Any, body: int, offset: np.ndarray, dyaw: float, n: int) -> None:
        import pybullet as pb

        c = world.client
        pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=c)
        self.body, self.n, self.k = body, max(1, n), 0
        self.p0, self.offset = np.asarray(pos), np.asarray(offset, dtype=float)
        self.e0, self.dyaw = np.asarray(pb.getEulerFromQuaternion(orn)), float(dyaw)

    def __call__(self, world: Any) -> None:
        import pybullet as pb

        c = world.client
        self.k += 1
        s = self.k / self.n
        euler = self.e0 + np.array([0.0, 0.0, s * self.dyaw])
        pb.resetBasePositionAndOrientation(self.body, (self.p0 + s * self.offset).tolist(),
                                           pb.getQuaternionFromEuler(euler.tolist()), physicsClientId=c)
        pb.resetBaseVelocity(self.body, [0, 0, 0], [0, 0, 0], physicsClientId=c)
        if self.k >= self.n:
            world.tick_hooks.remove(self)


def slide(obj: str, distance: tuple[float, float], dyaw: tuple[float, float] = (0.0, 0.0),
          duration: float = 0.25, direction: Callable[[Any], np.ndarray] | None = None) -> Effect:
    """Effect: move ``obj`` horizontally by a distance uniform in ``distance`` (m) along ``direction(world)``
    (a unit (2,) vector; default a uniform random direction) and turn it by a yaw uniform in ``dyaw``."""

    def effect(world: Any, rng: np.random.Generator) -> None:
        d = rng.uniform(*distance)
        if direction is None:
            a = rng.uniform(0, 2 * np.pi)
            u = np.array([np.cos(a), np.sin(a)])
        else:
            u = np.asarray(direction(world), dtype=float)
        yaw = rng.uniform(*dyaw) * rng.choice([-1.0, 1.0])
        offset = np.array([*(d * u), 0.0])
        body = world.body_of(obj)
        world.tick_hooks.append(_Slide(world, body, offset, yaw, round(duration / world.dt)))
        world.events.log(world.t, "object_moved", obj, offset=offset.tolist(), dyaw=yaw)

    return effect


def drop_held() -> Effect:
    """Effect: the gripper loses the object it holds (fingers stay closed; the policy does not know)."""

    def effect(world: Any, rng: np.random.Generator) -> None:
        held = world.robot.ee.detach()
        world.events.log(world.t, "drop", world.name_of(held))

    return effect


def turn_in_grasp(angle: tuple[float, float], axis: int = 0) -> Effect:
    """Effect: rotate the held object about the tool's ``axis`` (0 x, 1 y, 2 z) by an angle uniform in
    ``angle`` radians (random sign), keeping the grasp point fixed: a perturbed end-effector joint."""

    def effect(world: Any, rng: np.random.Generator) -> None:
        import pybullet as pb

        ee = world.robot.ee
        att = ee.attachment()
        if att is None:
            return
        body, rel_pos, rel_orn, link = att
        a = float(rng.uniform(*angle) * rng.choice([-1.0, 1.0]))
        axis_v = [0.0, 0.0, 0.0]
        axis_v[axis] = 1.0
        q = pb.getQuaternionFromAxisAngle(axis_v, a)
        tip = np.array([0.0, 0.0, float(getattr(ee, "tip_length", 0.0))])  # the grasp point, tool frame
        turned, new_orn = pb.multiplyTransforms([0, 0, 0], q, (np.asarray(rel_pos) - tip).tolist(), rel_orn)
        new_pos = (np.asarray(turned) + tip).tolist()
        ee.detach()
        c = world.client
        tpos, torn = pb.getBasePositionAndOrientation(ee.body, physicsClientId=c)
        wpos, worn = pb.multiplyTransforms(tpos, torn, new_pos, new_orn)
        pb.resetBasePositionAndOrientation(body, wpos, worn, physicsClientId=c)
        pb.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=c)
        ee.attach(body, new_pos, new_orn, link)
        world.events.log(world.t, "grasp_perturbed", world.name_of(body), angle=a, axis=axis)

    return effect


def lay_flat(obj: str, offset: tuple[float, float, float] | Callable[[Any], Any] = (0.0, 0.0, 0.0),
             roll: float = np.pi / 2, z: float = 0.03) -> Effect:
    """Effect: knock ``obj`` over: lay it on the table on its side (by default its local y axis vertical;
    ``roll`` about its local x, 0 keeps local z up), its centre at height ``z``, shifted horizontally by
    ``offset`` ((3,) or ``offset(world)``); random yaw."""

    def effect(world: Any, rng: np.random.Generator) -> None:
        import pybullet as pb

        c = world.client
        body = world.body_of(obj)
        shift = offset(world) if callable(offset) else offset
        pos = np.asarray(pb.getBasePositionAndOrientation(body, physicsClientId=c)[0]) + np.asarray(shift)
        yaw = rng.uniform(-np.pi, np.pi)
        orn = pb.getQuaternionFromEuler([roll, 0.0, yaw])
        pb.resetBasePositionAndOrientation(body, [pos[0], pos[1], z], orn, physicsClientId=c)
        pb.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=c)
        world.events.log(world.t, "object_knocked", obj, pos=pos.tolist())

    return effect
