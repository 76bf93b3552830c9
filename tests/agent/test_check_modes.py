"""The reactive-only / proactive-only switch (``AgentConfig.checks``): which constraints a subgoal keeps, and a
subgoal left with none ends when the policy says it is done (fakes for every stage, see ``loop_fakes``)."""

from __future__ import annotations

import pytest
from loop_fakes import (
    RULES,
    Coder,
    History,
    MovePolicy,
    Painter,
    Planner,
    Runtime,
    Tracker,
    World,
    _subgoal,
    user_loop,
)

from code_as_monitor.agent.check_modes import CHECK_MODES, kept_constraints
from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig, MonitorConfig
from code_as_monitor.agent.decision import DecisionKind
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.core import Constraint, Phase
from code_as_monitor.core.errors import ConfigError


def _constraints() -> list[Constraint]:
    return [Constraint("a", "a", Phase.DURING, proactive=True), Constraint("b", "b", Phase.DURING),
            Constraint("c", "c", Phase.UPON), Constraint("d", "d", Phase.UPON, proactive=True)]


def test_modes_keep_the_constraints_by_their_proactive_flag_whatever_their_phase() -> None:
    cs = _constraints()
    assert [c.id for c in kept_constraints(cs, "all")] == ["a", "b", "c", "d"]
    assert [c.id for c in kept_constraints(cs, "reactive")] == ["b", "c"]
    assert [c.id for c in kept_constraints(cs, "proactive")] == ["a", "d"]
    assert set(CHECK_MODES) == {"all", "reactive", "proactive"}


@pytest.mark.parametrize("bad", ["both", "", None, 1, "Reactive"])
def test_a_bad_mode_is_a_config_error_naming_it(bad: object) -> None:
    with pytest.raises(ConfigError, match="checks"):
        AgentConfig(checks=bad)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="checks"):
        MonitorConfig(checks=bad)  # type: ignore[arg-type]


def _run(checks: str, proactive_attached: bool = False) -> tuple[list, list, Planner, MovePolicy]:
    w = World(t_drop=0.3)
    sg = _subgoal("move block")
    sg.constraints[0].proactive = proactive_attached
    planner = Planner([sg])
    events: list = []
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History, AgentConfig(checks=checks))
    m = Monitor(planner, checker, on_event=lambda kind, **f: events.append((kind, f)))
    policy = MovePolicy(w)
    decisions = user_loop(m, w, policy)  # 50 Hz with the policy's 0.02 s step: one policy step per frame
    return decisions, events, planner, policy


def test_reactive_only_still_halts_on_the_reactive_drop_check() -> None:
    decisions, events, _, policy = _run("reactive")
    assert any(d.halt for d in decisions) and policy.halts >= 1
    assert [f["constraint_id"] for k, f in events if k == "alarm"] == ["attached"]
    assert not any(k == "checks_dropped" for k, _ in events), "both fake constraints are reactive"


def test_proactive_only_drops_the_reactive_checks_and_lets_the_policy_finish() -> None:
    decisions, events, _, policy = _run("proactive")
    dropped = [f for k, f in events if k == "checks_dropped"]
    assert dropped and dropped[0]["dropped"] == ["attached", "arrived"]
    assert not any(d.halt for d in decisions) and policy.halts == 0
    assert not any(k == "alarm" for k, _ in events), "the drop goes unseen without the reactive check"
    ends = [f for k, f in events if k == "subgoal_end"]
    assert ends[0]["outcome"] == "success" and "no proactive check" in ends[0]["reason"]
    assert not any(k in ("elements", "program") for k, _ in events), "nothing painted or coded for no check"


def test_proactive_only_keeps_a_proactive_check_and_it_still_halts() -> None:
    decisions, events, planner, _ = _run("proactive", proactive_attached=True)
    halt = next(d for d in decisions if d.halt)
    assert [a.constraint_id for a in halt.violations] == ["attached"] and halt.violations[0].proactive
    assert decisions[-1].kind is DecisionKind.TASK_DONE
    assert next(f["dropped"] for k, f in events if k == "checks_dropped") == ["arrived"]
    assert len(planner.calls) >= 2 and planner.calls[0] == (None, None)
