"""Baseline agents over the same Environment/Policy interface as the Code-as-Monitor agent.

- ``open-loop`` (:class:`OpenLoopAgent`, the paper's CLIPort column): the task's plan, fixed up front,
  played by the policy with no failure detection and no re-planning. It renders no frame and asks no
  VLM.
- ``inner-monologue`` (:class:`CheckingAgent` with ``period_s=None``): the planner proposes a subgoal,
  the policy runs it to its end, then ONE observation is rendered and a VQA success detector is asked
  about each of the subgoal's constraints; any "no" is fed back and the planner re-plans
  (paper: "queries the VLM only at the end of each subgoal").
- ``doremi`` (:class:`CheckingAgent` with ``period_s=k``): during execution, every ``k`` seconds of
  environment time, one observation is rendered and the VQA is asked about every ``during`` constraint
  (a "no" halts the policy and re-plans) and every ``upon`` constraint (all "yes" completes the
  subgoal early, which is how a never-ending skill gets stopped; not for a skill that runs to its end, the pour:
  :data:`~code_as_monitor.vlm.skills.RUN_TO_END`, as for CaM); when the policy ends, the ``upon`` constraints are
  asked once more.

Neither baseline halts the policy when the time limit is reached: running out of time is not a
decision to stop (the rope task counts a halt within the limit as the robot's decision).

The two checking baselines run in the same :class:`~code_as_monitor.agent.monitor.Monitor` as
Code-as-Monitor (the same planner loop, bounds and feedback); only the per-subgoal checker differs.
Every "no" is recorded as an :class:`~code_as_monitor.agent.records.Alarm` (proactive when its
constraint is), so the benchmark scores all methods' detections the same way.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from code_as_monitor.agent.drive import drive
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.agent.records import DEFAULT_MAX_REPLANS, DEFAULT_MAX_SUBGOALS, EpisodeLog, SubgoalRecord
from code_as_monitor.agent.subgoal import MonitorContext, SubgoalEnd, runs_to_end
from code_as_monitor.core.constraints import Action, Constraint, Phase, Subgoal
from code_as_monitor.core.observation import Observation
from code_as_monitor.core.policy import Policy
from code_as_monitor.core.registry import Choice, check_positive
from code_as_monitor.vlm.skills import RUN_TO_END

log = logging.getLogger(__name__)

EventFn = Callable[..., Any]
FrameFn = Callable[[Observation, str], None]


@dataclass
class BaselineConfig(Choice):
    """Base of the baseline configs. ``max_replans``/``max_subgoals``: the same bounds as CaM's agent."""

    max_replans: int = DEFAULT_MAX_REPLANS
    max_subgoals: int = DEFAULT_MAX_SUBGOALS

    def __post_init__(self) -> None:
        check_positive(type(self).__name__, "max_replans", self.max_replans, allow_zero=True)
        check_positive(type(self).__name__, "max_subgoals", self.max_subgoals)


@BaselineConfig.register("open-loop")
@dataclass
class OpenLoopConfig(BaselineConfig):
    """The policy alone on the plan fixed up front (the paper's CLIPort column)."""


@BaselineConfig.register("inner-monologue")
@dataclass
class InnerMonologueConfig(BaselineConfig):
    """Success detection by VQA at the end of each subgoal, then re-planning."""


@BaselineConfig.register("doremi")
@dataclass
class DoReMiConfig(BaselineConfig):
    """Periodic VQA during execution. ``k_s``: seconds of environment time between checks."""

    k_s: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        check_positive("doremi", "k_s", self.k_s)


def _noop(kind: str, **fields: Any) -> None:
    return None


class OpenLoopAgent:
    """Plays ``plan`` through the policy; no observation, no detection (see the module docstring)."""

    def __init__(self, plan: list[Action], time_limit_s: float | None = None, on_event: EventFn | None = None,
                 on_tick: Callable[[], None] | None = None) -> None:
        self.plan = list(plan)
        self.time_limit_s = time_limit_s
        self.emit = on_event or _noop
        self.on_tick = on_tick

    def run(self, instruction: str, env: Any, policy: Policy) -> EpisodeLog:
        ep = EpisodeLog(instruction)
        self.emit("episode_start", t=env.t, instruction=instruction)
        for action in self.plan:
            t0 = env.t
            policy.start(action)
            while not policy.done and not self._out_of_time(env):
                policy.step()
                if self.on_tick is not None:
                    self.on_tick()
            outcome = "success" if policy.done else "timeout"
            ep.subgoals.append(SubgoalRecord(f"{action.skill} {action.args}", action.skill, outcome,
                                             "policy finished" if policy.done else "time limit", t0, env.t))
            if outcome == "timeout":  # no halt: running out of time is not a decision to stop
                ep.stop_reason = "time limit"
                break
        else:
            ep.finished = True
            ep.stop_reason = "plan finished"
        ep.t_end = env.t
        self.emit("episode_end", t=env.t, finished=ep.finished, stop_reason=ep.stop_reason, replans=0)
        return ep

    def _out_of_time(self, env: Any) -> bool:
        return self.time_limit_s is not None and env.t >= self.time_limit_s


class VQAChecker:
    """The per-subgoal part of the Inner-Monologue-style (``period_s=None``) and DoReMi-style
    (``period_s=k``) baselines, plugged into the same :class:`~code_as_monitor.agent.monitor.Monitor`
    as Code-as-Monitor (see the module docstring for what each asks and when).

    Args:
        vqa: :class:`~code_as_monitor.baselines.vqa.VQA` (one image per question).
        period_s: seconds between checks during execution; None checks only when a subgoal ends.
        ask_all_at_end: at the end of a subgoal, ask every constraint (Inner Monologue) instead of
            only the ``upon`` ones (DoReMi, which has watched the ``during`` ones all along).
        on_frame: called with every observation it looks at and a banner (for sample videos).
        run_to_end: skills never ended early on a "yes" to every upon question (they are asked at the end only).
    """

    def __init__(self, vqa: Any, period_s: float | None, ask_all_at_end: bool,
                 on_frame: FrameFn | None = None, run_to_end: Collection[str] = RUN_TO_END) -> None:
        self.vqa = vqa
        self.run_to_end = tuple(run_to_end)
        self.period_s = period_s
        self.ask_all_at_end = ask_all_at_end
        self.on_frame = on_frame
        self.frames = 0
        self._next_check = float("inf")

    def _seen(self, obs: Observation, banner: str = "") -> None:
        self.frames += 1
        if self.on_frame is not None:
            self.on_frame(obs, banner)

    def start_episode(self, obs: Observation) -> None:
        self._seen(obs)  # the first subgoal is planned on it

    def close(self) -> None:
        return None

    def begin(self, index: int, subgoal: Subgoal, obs: Observation, ctx: MonitorContext) -> SubgoalEnd | None:
        self._subgoal = subgoal
        self._during = [c for c in subgoal.constraints if c.phase is Phase.DURING]
        self._upon = [c for c in subgoal.constraints if c.phase is Phase.UPON]
        self._next_check = obs.t + self.period_s if self.period_s else float("inf")
        self._ctx = ctx
        return None

    def frame_due(self, t: float, policy_done: bool) -> bool:
        return self._ctx.out_of_time(t) or policy_done or t + 1e-9 >= self._next_check

    def frame(self, obs: Observation, policy_done: bool, ctx: MonitorContext) -> SubgoalEnd | None:
        if ctx.out_of_time(obs.t):  # no halt: running out of time is not a decision to stop
            self._seen(obs)
            return SubgoalEnd("timeout", "time limit reached during the subgoal")
        sg = self._subgoal
        if not policy_done:
            self._next_check += self.period_s or 0.0
            self._seen(obs)
            bad = self._ask(self._during, obs, ctx)
            if bad:
                c, ans = bad[0]
                ctx.alarm(sg, c.id, c.phase.value, ans.reason, obs.t)
                return SubgoalEnd("violated", f"{c.id}: {ans.reason}", halt=True)
            if self._upon and not runs_to_end(sg, self.run_to_end) and not self._ask(self._upon, obs, ctx):
                ctx.emit("early_halt", t=obs.t, reason="all upon constraints answered yes")
                return SubgoalEnd("success", "all upon constraints answered yes", halt=True)
            return None
        self._seen(obs, "subgoal end")
        bad = self._ask(sg.constraints if self.ask_all_at_end else self._upon, obs, ctx)
        if bad:
            c, ans = bad[0]
            ctx.alarm(sg, c.id, c.phase.value, ans.reason, obs.t)
            return SubgoalEnd("reactive_failure", f"{c.id}: {ans.reason}")
        return SubgoalEnd("success", "policy finished; the success detector said yes")

    def _ask(self, constraints: list[Constraint], obs: Observation,
             ctx: MonitorContext) -> list[tuple[Constraint, Any]]:
        """Ask each constraint on ``obs``; returns the (constraint, answer) pairs answered "no"."""
        noes = []
        for c in constraints:
            ans = self.vqa.ask(c, obs)
            ctx.emit("vqa", t=obs.t, constraint_id=c.id, yes=ans.yes, reason=ans.reason)
            if not ans.yes:
                noes.append((c, ans))
        return noes


class CheckingAgent:
    """Inner-Monologue-style (``period_s=None``) or DoReMi-style (``period_s=k``) closed loop: a
    :class:`VQAChecker` in a :class:`~code_as_monitor.agent.monitor.Monitor`, driven by
    :func:`~code_as_monitor.agent.drive.drive` like Code-as-Monitor.

    Args:
        planner: ``next_subgoal(instruction, images, objects, previous, feedback) -> Subgoal``.
        vqa, period_s, ask_all_at_end, on_frame: see :class:`VQAChecker`.
    """

    def __init__(self, planner: Any, vqa: Any, config: BaselineConfig, period_s: float | None,
                 ask_all_at_end: bool, time_limit_s: float | None = None, on_event: EventFn | None = None,
                 on_frame: FrameFn | None = None) -> None:
        self.planner = planner
        self.cfg = config
        self.checker = VQAChecker(vqa, period_s, ask_all_at_end, on_frame=on_frame)
        self.monitor = Monitor(planner, self.checker, max_replans=config.max_replans,
                               max_subgoals=config.max_subgoals, time_limit_s=time_limit_s, on_event=on_event)

    @property
    def frames(self) -> int:
        """Observations the method looked at (rendered for it)."""
        return self.checker.frames

    def run(self, instruction: str, env: Any, policy: Policy) -> EpisodeLog:
        return drive(self.monitor, instruction, env, policy)


__all__ = [
    "BaselineConfig",
    "CheckingAgent",
    "DoReMiConfig",
    "InnerMonologueConfig",
    "OpenLoopAgent",
    "OpenLoopConfig",
    "VQAChecker",
]
