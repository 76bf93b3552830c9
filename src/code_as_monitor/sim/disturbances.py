"""Composable disturbances, registered by name, each logging its events to ``world.events``.

A disturbance is installed on a world (tick hooks) and wraps the policy (to perturb what the policy
computes); wrappers compose: ``apply_disturbances(world, policy, [drop, noise])``.

- ``drop`` (:class:`Drop`, parameter ``p``): while the suction holds an object, a *drop decision* is
  taken every ``1 / check_hz`` seconds of holding (the first one period after the attach); with
  probability ``p`` the suction lets the object go (it stays switched on; the policy does not know).
  In CLIPort a "step" is a primitive-level action step, not a physics tick; ``check_hz = 1`` gives
  about two decisions per carry in ``stack-in-order`` (see that task's docstring).
  Events: ``drop`` (obj, ``decision``), then ``block_fell`` (obj, ``pos``) when it comes to rest.
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
    """``p``: release probability per drop decision; ``check_hz``: decisions per second of holding."""

    p: float = 0.0
    check_hz: float = 1.0

    def __post_init__(self) -> None:
        check_probability("drop", "p", self.p)
        check_positive("drop", "check_hz", self.check_hz)

    def build(self, seed: Any) -> Drop:
        return Drop(self.p, self.check_hz, seed)


class Drop(Disturbance):
    """Random suction release while holding (see the module docstring)."""

    def __init__(self, p: float, check_hz: float = 1.0, seed: Any = 0) -> None:
        super().__init__(seed)
        self.p, self.check_hz = float(p), float(check_hz)
        self.decisions = 0  # decisions taken so far
        self.releases = 0  # of which released
        self._held_ticks = 0
        self._falling: dict[int, float] = {}  # dropped body -> drop time

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
            period = max(1, round(1.0 / (self.check_hz * world.dt)))
            if self._held_ticks % period == 0:
                self.decisions += 1
                if self.rng.random() < self.p:
                    self.releases += 1
                    ee.detach()
                    self._held_ticks = 0
                    self._falling[held] = world.t
                    world.events.log(world.t, "drop", world.name_of(held), decision=self.decisions)
        for body, t0 in list(self._falling.items()):
            v = np.linalg.norm(pb.getBaseVelocity(body, physicsClientId=world.client)[0])
            if world.t - t0 > 0.1 and v < 0.02:
                pos = pb.getBasePositionAndOrientation(body, physicsClientId=world.client)[0]
                world.events.log(world.t, "block_fell", world.name_of(body), pos=list(pos), dropped_at=t0)
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
        if action.skill == "place_on":
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
