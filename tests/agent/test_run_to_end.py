"""A skill that runs to its end (``AgentConfig.run_to_end``, default the pour) is not halted when its upon checks first
hold; any other skill is, by CaM's checker and by DoReMi's alike. Fakes from ``loop_fakes``: one block moved along x
to the policy's stop at 0.3 m; the upon check "arrived" holds from x >= 0.2 m."""

from __future__ import annotations

import pytest
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig, MonitorConfig
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.baselines.agents import VQAChecker
from code_as_monitor.baselines.vqa_pixels import VQAAnswer
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.vlm.skills import DEFAULT_SKILLS, RUN_TO_END


def _cam(cfg: AgentConfig) -> tuple[Monitor, MovePolicy, World, list]:
    w = World()
    events: list = []
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History, cfg)
    m = Monitor(Planner([_subgoal("move block", during=False)]), checker, max_replans=0,
                on_event=lambda k, **f: events.append((k, f)))
    policy = MovePolicy(w, stop_at=0.3)
    user_loop(m, w, policy)
    return m, policy, w, events


def test_a_skill_that_runs_to_its_end_is_judged_at_its_end_not_halted_when_its_upon_check_first_holds():
    m, policy, w, events = _cam(AgentConfig(run_to_end=("move",)))
    assert [s.outcome for s in m.episode.subgoals] == ["success"]
    assert policy.halts == 0 and w.x == pytest.approx(0.3)  # the motion finished
    assert not [k for k, _ in events if k == "early_halt"]


def test_any_other_skill_is_halted_as_soon_as_its_upon_checks_hold():
    m, policy, w, events = _cam(AgentConfig())  # run_to_end: the pour only
    assert [s.outcome for s in m.episode.subgoals] == ["success"]
    assert policy.halts == 1 and w.x < 0.25
    assert [k for k, _ in events if k == "early_halt"] == ["early_halt"]


class YesVQA:
    name = "yes"

    def ask(self, constraint, obs):
        return VQAAnswer(True, "yes")


@pytest.mark.parametrize(("run_to_end", "halted"), [(("move",), False), ((), True)])
def test_doremi_does_not_end_a_skill_that_runs_to_its_end_early_either(run_to_end, halted):
    w = World()
    events: list = []
    checker = VQAChecker(YesVQA(), 0.1, False, run_to_end=run_to_end)
    m = Monitor(Planner([_subgoal("move block", during=False)]), checker, max_replans=0,
                on_event=lambda k, **f: events.append((k, f)))
    policy = MovePolicy(w, stop_at=0.3)
    user_loop(m, w, policy)
    assert [s.outcome for s in m.episode.subgoals] == ["success"]
    assert (policy.halts == 1) is halted and (w.x < 0.25) is halted


def test_the_default_names_skills_of_the_table_and_bad_values_are_named():
    assert set(RUN_TO_END) <= set(DEFAULT_SKILLS) and AgentConfig().run_to_end == RUN_TO_END
    assert MonitorConfig(run_to_end=["pour", "screw"]).agent_config().run_to_end == ("pour", "screw")
    for bad in ("pour", ["pour", 3], [""], None):
        with pytest.raises(ConfigError, match="run_to_end"):
            AgentConfig(run_to_end=bad)
