"""Closed-loop semantics with fakes for every stage (the real stages are tested in their own packages).

The world is one block moving along x; checks are trusted Python callables standing in for the sandbox.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

from code_as_monitor.agent.loop import Agent, AgentConfig
from code_as_monitor.core import Action, Constraint, Element, ElementSpec, Observation, Phase, Subgoal, Verdict
from code_as_monitor.core.errors import ConfigError
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
    def paint(self, obs, subgoal):
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


def _agent(world: World, planner: Planner, **cfg) -> tuple[Agent, list[tuple[str, dict]]]:
    events: list[tuple[str, dict]] = []
    agent = Agent(
        planner, Coder(), Painter(), Tracker(world), Runtime(RULES), History,
        AgentConfig(**cfg), on_event=lambda kind, **f: events.append((kind, f)),
    )
    return agent, events


def test_upon_satisfied_halts_a_still_moving_policy_early() -> None:
    w = World()
    planner = Planner([_subgoal("move block")])
    agent, events = _agent(w, planner)
    policy = MovePolicy(w)
    ep = agent.run("move the block", w, policy)
    assert ep.finished
    assert [s.outcome for s in ep.subgoals] == ["success"]
    assert policy.halts == 1, "the policy would have gone on to x=0.3"
    assert 0.2 <= w.x < 0.3
    assert any(k == "early_halt" for k, _ in events)


def test_during_violation_halts_and_feeds_the_reason_back() -> None:
    w = World(t_drop=0.3)
    planner = Planner([_subgoal("move block"), _subgoal("move block again", during=False)])
    agent, _ = _agent(w, planner)
    policy = MovePolicy(w)
    ep = agent.run("move the block", w, policy)
    assert ep.subgoals[0].outcome == "violated"
    assert ep.subgoals[0].t_end == pytest.approx(0.3, abs=0.11), "detected within one frame of the drop"
    assert "attached" in planner.calls[1][1] and planner.calls[1][1].startswith("failure")
    assert ep.alarms and ep.alarms[0].constraint_id == "attached"
    assert ep.replans == 1
    assert ep.finished


def test_policy_done_with_upon_false_is_a_reactive_failure() -> None:
    w = World()
    planner = Planner([_subgoal("move block", during=False)])
    agent, _ = _agent(w, planner)
    policy = MovePolicy(w, stop_at=0.1)  # stops short of x >= 0.2
    ep = agent.run("move the block", w, policy)
    assert ep.subgoals[0].outcome == "reactive_failure"
    assert ep.alarms[0].phase == "upon"


def test_replans_are_bounded() -> None:
    w = World()
    planner = Planner([_subgoal(f"try {i}", during=False) for i in range(10)])
    agent, _ = _agent(w, planner, max_replans=2)
    ep = agent.run("move the block", w, MovePolicy(w, stop_at=0.1))
    assert not ep.finished
    assert len(ep.subgoals) == 3
    assert "re-plans" in ep.stop_reason


def test_time_limit_stops_a_subgoal() -> None:
    w = World()
    planner = Planner([_subgoal("slow move", during=False)])
    agent, _ = _agent(w, planner, time_limit_s=0.5)
    policy = MovePolicy(w, speed=0.01)
    ep = agent.run("move the block", w, policy)
    assert ep.subgoals[0].outcome == "timeout"
    assert ep.stop_reason == "time limit"
    assert policy.halts == 0, "running out of time is not a monitor decision to halt"


@pytest.mark.parametrize("field_, value", [("frame_hz", 0), ("max_replans", -1), ("history_len", 1)])
def test_bad_config_names_the_field(field_: str, value: float) -> None:
    with pytest.raises(ConfigError, match=field_):
        AgentConfig(**{field_: value})


def test_checks_on_stale_elements_give_no_verdict() -> None:
    """A drop seen only through a stale element must not raise an alarm; once fresh again, it does."""
    w = World(t_drop=0.1)
    planner = Planner([_subgoal("move block")])
    agent, events = _agent(w, planner)

    stale_until = 0.5
    real_step = Tracker.step

    def step(self, obs):
        tr = real_step(self, obs)
        tr.stale = {i: np.array([obs.t < stale_until]) for i in tr.points}
        return tr

    agent.tracker.step = step.__get__(agent.tracker)
    ep = agent.run("move the block", w, MovePolicy(w))
    assert ep.alarms and ep.alarms[0].t >= stale_until
    assert any(k == "verdicts_unknown" and f["constraints"] for k, f in events)


@pytest.mark.parametrize("refresh", [True, False])
def test_upon_checks_are_judged_on_re_painted_elements_when_the_policy_finishes(refresh: bool) -> None:
    """The tracker reports the block 15 cm behind where it is; the painter sees it where it is."""
    w = World()
    planner = Planner([_subgoal("move block", during=False)])
    agent, events = _agent(w, planner, refresh_on_done=refresh, max_replans=0)
    real_step = Tracker.step

    def drifted(self, obs):
        tr = real_step(self, obs)
        tr.points = {i: p - np.array([[0.15, 0.0, 0.0]]) for i, p in tr.points.items()}
        return tr

    agent.tracker.step = drifted.__get__(agent.tracker)
    agent.painter.build_element = lambda obs, i, spec: Element.point(i, spec.name, [w.x, 0.0, 0.1], (spec.obj, ""))
    ep = agent.run("move the block", w, MovePolicy(w, stop_at=0.25))
    assert ep.subgoals[0].outcome == ("success" if refresh else "reactive_failure")
    assert any(k == "final_check" for k, _ in events)
