"""Fakes for every stage of the closed loop (the real stages are tested in their own packages).

The world is one block moving along x; checks are trusted Python callables standing in for the sandbox.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from code_as_monitor.core import Action, Constraint, Element, ElementSpec, Observation, Phase, Subgoal, Verdict
from code_as_monitor.painter.painter import PaintResult, assign_element_ids


class World:
    """Block at x(t); the policy moves it at `speed` m/s towards `goal`; optional drop at t_drop."""

    def __init__(self, t_drop: float | None = None) -> None:
        self.t = 0.0
        self.x = 0.0
        self.t_drop = t_drop
        self.dropped = False

    def observe(self) -> Observation:
        return Observation(t=self.t, views={}, objects=["block"])


class MovePolicy:
    def __init__(self, world: World, dt: float = 0.02, speed: float = 0.2, stop_at: float = 0.3) -> None:
        self.w, self.dt, self.speed, self.stop_at = world, dt, speed, stop_at
        self._done = True
        self.halts = 0
        self.started: list[Action] = []

    def start(self, action: Action) -> None:
        self.started.append(action)
        self._done = False

    def step(self) -> None:
        self.w.t += self.dt
        if self._done:
            return
        if self.w.t_drop is not None and not self.w.dropped and self.w.t >= self.w.t_drop:
            self.w.dropped = True
        self.w.x = min(self.stop_at, self.w.x + self.speed * self.dt)
        if self.w.x >= self.stop_at:
            self._done = True

    def halt(self) -> None:
        self.halts += 1
        self._done = True

    @property
    def done(self) -> bool:
        return self._done


@dataclass
class Planner:
    plans: list[Subgoal]
    calls: list[tuple[str | None, str | None]] = field(default_factory=list)

    def next_subgoal(self, instruction, images, objects, previous, feedback):
        self.calls.append((previous.text if previous else None, feedback))
        return self.plans.pop(0) if self.plans else Subgoal("done", done=True)


class Coder:
    def __init__(self) -> None:
        self.checked = 0

    def write_program(self, subgoal, elements, images, check, max_retries=2, feedback=None):
        check("def check_x(E, H, t):\n    return True, 'ok'\n")
        self.checked += 1
        return "source"


class Painter:
    def paint(self, obs, subgoal, known=None):
        specs = assign_element_ids(subgoal)
        els = [Element.point(i, s.name, np.zeros(3), (s.obj, s.part)) for i, s in specs.items()]
        return PaintResult(els, specs, {}, [], 0.0)

    def build_element(self, obs, i, spec):
        return None


@dataclass
class Track:
    points: dict[int, np.ndarray]
    stale: dict[int, np.ndarray]


class Tracker:
    def __init__(self, world: World) -> None:
        self.w = world

    def reset(self, obs, elements) -> None:
        self.ids = [e.id for e in elements]

    def set_reacquire(self, fn) -> None:
        self.fn = fn

    def step(self, obs) -> Track:
        z = -1.0 if self.w.dropped else 0.1
        return Track({i: np.array([[self.w.x, 0.0, z]]) for i in self.ids}, {})


class Runtime:
    """Evaluates trusted callables: name -> fn(E, t) -> bool."""

    def __init__(self, rules: dict[str, object]) -> None:
        self.rules = rules

    def start(self, source, constraints, positions, H, ht, t) -> None:
        self.constraints = constraints

    def step(self, points, H, ht, t) -> list[Verdict]:
        out = []
        for c in self.constraints:
            ok = bool(self.rules[c.id](points, t))
            out.append(Verdict(c.id, c.phase, ok, f"{c.id} {'holds' if ok else 'violated'}", t=t))
        return out


class History:
    def __init__(self, n: int) -> None:
        self.items: list[tuple[float, dict]] = []

    def push(self, t, pts) -> None:
        self.items.append((t, pts))

    def arrays(self):
        ids = self.items[0][1].keys() if self.items else []
        H = {i: np.stack([np.asarray(p[i]) for _, p in self.items]) for i in ids}
        return H, np.array([t for t, _ in self.items])


def _subgoal(text: str, during: bool = True, upon: bool = True) -> Subgoal:
    spec = ElementSpec("block", "block", "", "point")
    cs = []
    if during:
        cs.append(Constraint("attached", "block stays attached", Phase.DURING, [spec], proactive=False))
    if upon:
        cs.append(Constraint("arrived", "block reached x >= 0.2", Phase.UPON, [spec]))
    return Subgoal(text, cs, Action("move", {"obj": "block"}))


RULES = {
    "attached": lambda P, t: all(p[0, 2] > 0 for p in P.values()),
    "arrived": lambda P, t: all(p[0, 0] >= 0.2 for p in P.values()),
}


def user_loop(monitor: Any, world: World, policy: MovePolicy, camera_hz: float = 50.0, t_max: float = 5.0) -> list:
    """A user's control loop: a camera at ``camera_hz``, the policy stepped in between, every frame
    handed to the monitor whatever its rate."""
    decisions = []
    monitor.start("move the block")
    while world.t < t_max:
        d = monitor.step(world.observe(), policy_done=policy.done)
        decisions.append(d)
        if d.halt:
            policy.halt()
        if d.action is not None:
            policy.start(d.action)
        if d.finished:
            break
        for _ in range(max(1, round(1 / (camera_hz * policy.dt)))):
            policy.step()
    return decisions
