"""Composable disturbances, registered by name, each logging its events to ``world.events``.

A disturbance is installed on a world (tick hooks) and wraps the policy (to perturb what the policy
computes); wrappers compose: ``apply_disturbances(world, policy, [drop, noise])``.

- ``drop`` (:class:`Drop`, parameter ``p``): while the suction holds an object, a *drop decision* is
  taken every ``1 / check_hz`` seconds of holding (the first one period after the attach); with
  probability ``p`` the suction lets the object go (it stays switched on; the policy does not know).
  In CLIPort a "step" is a primitive-level action step, not a physics tick; ``check_hz = 1`` gives
  about two decisions per carry in ``stack-in-order`` (see that task's docstring).
  Events: ``drop`` (obj, ``decision``, ``skill`` and ``target`` of the action in progress), ``regrasped``
  (obj: the suction took it again within the same action, before or after it came to rest), and
  ``block_fell`` (obj, ``pos``,
  ``on``: the object it rests on or ``"table"``, ``target``, ``target_offset``: horizontal distance in metres
  from the target's centre, ``on_target``: it rests on the target within ``landing_tol``) when it comes to
  rest. A drop that lands on its target is logged like any other; whether it changed the outcome is
  :mod:`code_as_monitor.bench.metrics`' call.
- ``placement_noise`` (:class:`PlacementNoise`, parameter ``q`` in cm): every ``place_on`` target the
  policy computes is offset by a vector of uniform direction and magnitude uniform in [0, q] cm.
  Event: ``placement_noise`` (obj, ``offset`` [dx, dy] metres, ``target``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.registry import Choice, check_positive, check_probability


@dataclass
class DisturbanceConfig(Choice):
    """Base of the disturbance configs."""

    def build(self, seed: Any) -> Disturbance:
        raise NotImplementedError


class Disturbance:
    """Base: no-op hooks. ``rng`` is private to the disturbance (``seed``: an int or a list of ints,
    derived from the world seed)."""

    def __init__(self, seed: Any) -> None:
        self.rng = np.random.default_rng(seed)

    def install(self, world: Any) -> None:
        """Register tick hooks on ``world``."""

    @staticmethod
    def paused(world: Any) -> bool:
        """No new disturbance starts while ``world.disturbances_paused`` (counterfactual rollouts ask "what if
        nothing were done", not "what if something else went wrong"); effects already under way go on."""
        return bool(getattr(world, "disturbances_paused", False))

    def wrap(self, policy: Any) -> Any:
        """Return the policy to use (default: unchanged)."""
        return policy


class PolicyWrapper:
    """Forwards the Policy protocol (and any other attribute) to the wrapped policy."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def start(self, action: Action) -> None:
        self.inner.start(action)

    def step(self) -> None:
        self.inner.step()

    def halt(self) -> None:
        self.inner.halt()

    @property
    def done(self) -> bool:
        return self.inner.done

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


# --- drop ------------------------------------------------------------------------------------------------------
@DisturbanceConfig.register("drop")
@dataclass
class DropConfig(DisturbanceConfig):
    """``p``: release probability per drop decision; ``check_hz``: decisions per second of holding;
    ``landing_tol``: metres off the target's centre within which a dropped object resting on its target counts
    as ``on_target`` (the task's placement tolerance; a drop while setting down on the ``table`` is on target
    wherever on the table it comes to rest)."""

    p: float = 0.0
    check_hz: float = 1.0
    landing_tol: float = 0.01

    def __post_init__(self) -> None:
        check_probability("drop", "p", self.p)
        check_positive("drop", "check_hz", self.check_hz)
        check_positive("drop", "landing_tol", self.landing_tol)

    def build(self, seed: Any) -> Drop:
        return Drop(self.p, self.check_hz, seed, landing_tol=self.landing_tol)


def current_action(world: Any) -> tuple[str, dict[str, Any]]:
    """(skill, args) of the last ``action_start`` in ``world.events`` (``("", {})`` before any)."""
    for e in reversed(world.events.events):
        if e["kind"] == "action_start":
            return str(e.get("skill", "")), dict(e.get("args") or {})
    return "", {}


def resting_on(world: Any, body: int, min_normal_z: float = 0.7) -> str:
    """Name of the object ``body`` rests on (a contact whose normal points up into it), ``"table"`` for the
    ground or the table, ``""`` when it rests on nothing that is known."""
    import pybullet as pb

    below: list[tuple[float, int]] = []
    for c in pb.getContactPoints(bodyA=body, physicsClientId=world.client):
        other, normal_on_b = c[2], c[7]
        if other != body and normal_on_b[2] >= min_normal_z:
            below.append((c[6][2], other))
    if not below:
        return ""
    name = world.name_of(max(below)[1])  # the highest support
    return name if name and name != "table" else "table"


class Drop(Disturbance):
    """Random suction release while holding (see the module docstring)."""

    def __init__(self, p: float, check_hz: float = 1.0, seed: Any = 0, landing_tol: float = 0.01) -> None:
        super().__init__(seed)
        self.p, self.check_hz, self.landing_tol = float(p), float(check_hz), float(landing_tol)
        self.decisions = 0  # decisions taken so far
        self.releases = 0  # of which released
        self._held_ticks = 0
        self._falling: dict[int, tuple[float, str]] = {}  # dropped body -> (drop time, the action's target)
        self._same_action: dict[int, tuple[float, int]] = {}  # dropped body -> (drop time, events seen then)

    def install(self, world: Any) -> None:
        world.tick_hooks.append(self._on_tick)

    def _on_tick(self, world: Any) -> None:
        import pybullet as pb

        ee = world.robot.ee
        held = ee.holding
        if held is None:
            self._held_ticks = 0
        else:
            self._held_ticks += 1
            if held in self._same_action:  # the suction took it again within the action that dropped it
                t0, _ = self._same_action.pop(held)
                self._falling.pop(held, None)
                world.events.log(world.t, "regrasped", world.name_of(held), dropped_at=t0)
            period = max(1, round(1.0 / (self.check_hz * world.dt)))
            if self._held_ticks % period == 0 and not self.paused(world):
                self.decisions += 1
                if self.rng.random() < self.p:
                    self.releases += 1
                    ee.detach()
                    self._held_ticks = 0
                    skill, args = current_action(world)
                    target = str(args.get("target", "")) if skill == "place_on" else ""
                    self._falling[held] = (world.t, target)
                    self._same_action[held] = (world.t, len(world.events.events))
                    world.events.log(world.t, "drop", world.name_of(held), decision=self.decisions, skill=skill,
                                     target=target)
        for body, (_, seen) in list(self._same_action.items()):
            if any(e["kind"] == "action_start" for e in world.events.events[seen:]):
                del self._same_action[body]  # a new action began: a later grasp is a recovery, not a regrasp
        for body, (t0, target) in list(self._falling.items()):
            v = np.linalg.norm(pb.getBaseVelocity(body, physicsClientId=world.client)[0])
            if world.t - t0 > 0.1 and v < 0.02:
                pos = np.asarray(pb.getBasePositionAndOrientation(body, physicsClientId=world.client)[0])
                on = resting_on(world, body)
                offset = None
                if target and target in world.objects:
                    offset = round(float(np.linalg.norm(pos[:2] - world.position(target)[:2])), 4)
                # "on the table" is the whole of a set-down's target (the policy picks any free spot on it)
                on_target = bool(target) and on == target and (
                    target == "table" or (offset is not None and offset <= self.landing_tol))
                world.events.log(world.t, "block_fell", world.name_of(body), pos=pos.tolist(), dropped_at=t0,
                                 on=on, target=target, target_offset=offset, on_target=on_target)
                del self._falling[body]


# --- placement noise ---------------------------------------------------------------------------------------------
@DisturbanceConfig.register("placement_noise")
@dataclass
class PlacementNoiseConfig(DisturbanceConfig):
    """``q``: maximum offset of a place target, centimetres."""

    q: float = 0.0

    def __post_init__(self) -> None:
        check_positive("placement_noise", "q", self.q, allow_zero=True)

    def build(self, seed: Any) -> PlacementNoise:
        return PlacementNoise(self.q, seed)


class PlacementNoise(Disturbance):
    """Offsets every ``place_on`` target (see the module docstring)."""

    def __init__(self, q_cm: float, seed: Any = 0) -> None:
        super().__init__(seed)
        self.q = float(q_cm) / 100.0  # metres

    def wrap(self, policy: Any) -> Any:
        return _NoisyPlace(policy, self)

    def offset(self) -> np.ndarray:
        """(2,) metres: uniform direction, magnitude uniform in [0, q]."""
        ang = self.rng.uniform(0.0, 2 * np.pi)
        r = self.rng.uniform(0.0, self.q)
        return r * np.array([np.cos(ang), np.sin(ang)])


class _NoisyPlace(PolicyWrapper):
    def __init__(self, inner: Any, noise: PlacementNoise) -> None:
        super().__init__(inner)
        self.noise = noise

    def start(self, action: Action) -> None:
        if action.skill == "place_on" and not self.noise.paused(self.inner.world):
            self.inner.validate(action)
            xy = np.asarray(self.inner.place_xy(action), dtype=float)
            off = self.noise.offset()
            action = Action(action.skill, {**action.args, "xy": (xy + off).tolist()})
            world = self.inner.world
            world.events.log(world.t, "placement_noise", str(action.args.get("obj", "")), offset=off.tolist(),
                             target=action.args.get("target", ""))
        self.inner.start(action)


def apply_disturbances(world: Any, policy: Any, disturbances: list[Disturbance]) -> Any:
    """Install each disturbance on ``world`` and wrap ``policy`` with each, in order; returns the outer policy."""
    for d in disturbances:
        d.install(world)
        policy = d.wrap(policy)
    return policy
