"""Baseline agents on a fake environment: when they look, what they ask, how they re-plan."""

from __future__ import annotations

from code_as_monitor.baselines.agents import CheckingAgent, DoReMiConfig, InnerMonologueConfig, OpenLoopAgent
from code_as_monitor.baselines.vqa_standin import VQAAnswer
from code_as_monitor.core.constraints import Action, Constraint, Phase, Subgoal
from code_as_monitor.core.observation import Observation


class Env:
    def __init__(self) -> None:
        self.t = 0.0
        self.renders = 0

    def observe(self) -> Observation:
        self.renders += 1
        return Observation(t=self.t, views={}, objects=["a"])


class Policy:
    """Each action takes ``length`` ticks of 0.1 s."""

    def __init__(self, env: Env, length: int = 30) -> None:
        self.env, self.length, self.left, self.halted = env, length, 0, 0

    def start(self, action: Action) -> None:
        self.left = self.length

    def step(self) -> None:
        self.left = max(0, self.left - 1)
        self.env.t = round(self.env.t + 0.1, 6)

    def halt(self) -> None:
        self.left, self.halted = 0, self.halted + 1

    @property
    def done(self) -> bool:
        return self.left == 0


class Planner:
    """Two subgoals, then done; remembers the feedback it got."""

    def __init__(self) -> None:
        self.feedback: list = []
        self.n = 0

    def next_subgoal(self, instruction, images, objects, previous, feedback):
        self.feedback.append(feedback)
        self.n += 1
        if self.n > 2 and feedback == "success":
            return Subgoal("done", done=True)
        cons = [Constraint("keep_x", "x stays", Phase.DURING, proactive=True), Constraint("at_y", "x at y", Phase.UPON)]
        return Subgoal(f"sub{self.n}", cons, Action("pick", {"obj": "a"}))


class VQA:
    name = "fake"

    def __init__(self, no_during_at: float | None = None) -> None:
        self.asked: list = []
        self.no_during_at = no_during_at

    def ask(self, c, obs):
        self.asked.append((c.id, obs.t))
        if c.id == "keep_x" and self.no_during_at is not None and obs.t >= self.no_during_at:
            self.no_during_at = None
            return VQAAnswer(False, "x moved")
        if c.id == "at_y" and obs.t < 2.95:  # only true once the action has run its course
            return VQAAnswer(False, "not yet")
        return VQAAnswer(True, "fine")


def test_inner_monologue_looks_only_at_subgoal_ends():
    env, planner, vqa = Env(), Planner(), VQA()
    agent = CheckingAgent(planner, vqa, InnerMonologueConfig(), period_s=None, ask_all_at_end=True)
    ep = agent.run("task", env, Policy(env))
    assert ep.finished and [s.outcome for s in ep.subgoals] == ["success", "success"]
    assert {t for _, t in vqa.asked} == {3.0, 6.0}  # both constraints, at each end only
    assert env.renders == 3 and agent.frames == 3  # the first plan + two subgoal ends


def test_doremi_checks_every_k_seconds_and_replans_on_no():
    env, planner, vqa = Env(), Planner(), VQA(no_during_at=1.0)
    agent = CheckingAgent(planner, vqa, DoReMiConfig(k_s=0.5), period_s=0.5, ask_all_at_end=False)
    ep = agent.run("task", env, Policy(env))
    during_times = [t for cid, t in vqa.asked if cid == "keep_x"]
    assert during_times[:2] == [0.5, 1.0]
    assert ep.subgoals[0].outcome == "violated" and ep.alarms[0].proactive and ep.alarms[0].t == 1.0
    assert planner.feedback[1].startswith("failure: keep_x: x moved")
    assert ep.finished and ep.replans == 1


def test_open_loop_renders_nothing():
    env = Env()
    ep = OpenLoopAgent([Action("pick", {"obj": "a"})] * 2, time_limit_s=None).run("t", env, Policy(env))
    assert ep.finished and env.renders == 0 and not ep.alarms and ep.t_end == 6.0
