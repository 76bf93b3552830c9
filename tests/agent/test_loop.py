"""Closed-loop semantics with fakes for every stage (the real stages are tested in their own packages).

The world is one block moving along x; checks are trusted Python callables standing in for the sandbox.
"""

from __future__ import annotations

import numpy as np
import pytest
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal

from code_as_monitor.agent.loop import Agent, AgentConfig
from code_as_monitor.core import Action, Constraint, Element, ElementSpec, Phase, Subgoal
from code_as_monitor.core.errors import ConfigError


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


def _set_subgoal(monotone: list[str]) -> Subgoal:
    """Upon: at least two of three rope beads have reached x >= 0.2 (more beads can only help)."""
    beads = [ElementSpec(f"rope bead {i}", "rope", f"bead_{i}", "point") for i in range(3)]
    c = Constraint("covered", "two beads reached x >= 0.2", Phase.UPON, beads, monotone=monotone)
    return Subgoal("drag the rope", [c], Action("move", {"obj": "rope"}))


def _drag_with_bead_0_stale(w: World, monotone: list[str], need: int):
    """Run :func:`_set_subgoal` in ``w`` with bead 0 stale on every frame and a check needing ``need`` beads at
    x >= 0.2: (the subgoal's result, the policy, the events)."""
    planner = Planner([_set_subgoal(monotone)])
    rules = {"covered": lambda P, t: sum(p[0, 0] >= 0.2 for p in P.values()) >= need}
    events: list[tuple[str, dict]] = []
    agent = Agent(planner, Coder(), Painter(), Tracker(w), Runtime(rules), History,
                  AgentConfig(max_replans=0), on_event=lambda kind, **f: events.append((kind, f)))
    real_step = Tracker.step

    def step(self, obs):
        tr = real_step(self, obs)
        tr.stale = {i: np.array([i == 0]) for i in tr.points}
        return tr

    agent.tracker.step = step.__get__(agent.tracker)
    policy = MovePolicy(w)
    ep = agent.run("drag the rope", w, policy)
    return ep.subgoals[0], policy, events


@pytest.mark.parametrize("monotone, need", [(["rope"], 2), ([], 2), (["rope"], 3)])
def test_a_set_check_with_unseen_members_is_judged_on_the_members_seen(monotone: list[str], need: int) -> None:
    """One bead is stale all along. A check over monotone members that holds on the two beads seen completes the
    subgoal (early halt, the reason names the unseen bead); without ``monotone`` it has no verdict; one that does
    not hold on those seen (three needed) has no verdict either: neither an early halt nor a failure read from
    the beads seen."""
    w = World()
    sg, policy, events = _drag_with_bead_0_stale(w, monotone, need)
    if monotone and need == 2:
        assert sg.outcome == "success" and policy.halts == 1
        assert "judged on the elements seen (unseen: [0])" in sg.reason
        assert any(k == "verdicts_unknown" and f["judged_on_seen"] == ["covered"] for k, f in events)
    else:
        assert policy.halts == 0, "no verdict: the policy runs to its end"
        assert sg.outcome == "reactive_failure" and "no verdict" in sg.reason


@pytest.mark.parametrize("release", [1.2, None])
def test_a_set_check_is_not_judged_on_the_members_seen_while_the_hand_is_engaged(release: float | None) -> None:
    """As above (two of three beads needed, one stale all along), but the gripper holds until ``release``: the members
    hidden then may be the ones in its grip, so the check waits for the release (the halt comes after it, not when
    the beads seen first hold at t = 1.0 s); held all along, it never has a verdict."""
    from code_as_monitor.core.observation import Observation, RobotState

    class HeldWorld(World):
        def observe(self) -> Observation:
            held = release is None or self.t < release - 1e-9
            return Observation(t=self.t, views={}, objects=["block"],
                               robot=RobotState(ee_pose=np.eye(4), gripper=1.0 if held else 0.0))

    sg, policy, _ = _drag_with_bead_0_stale(HeldWorld(), ["rope"], 2)
    if release is not None:
        assert sg.outcome == "success" and policy.halts == 1
        assert sg.t_end >= release - 1e-9, "not judged on the beads seen while the hand held"
        assert "judged on the elements seen" in sg.reason
    else:
        assert policy.halts == 0 and sg.outcome == "reactive_failure" and "no verdict" in sg.reason
