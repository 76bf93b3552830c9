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
  subgoal early, which is how a never-ending skill gets stopped); when the policy ends, the ``upon``
  constraints are asked once more.

Neither baseline halts the policy when the time limit is reached: running out of time is not a
decision to stop (the rope task counts a halt within the limit as the robot's decision).

Every "no" is recorded as an :class:`~code_as_monitor.agent.loop.Alarm` (proactive when its
constraint is), so the benchmark scores all methods' detections the same way.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from code_as_monitor.agent.loop import (
    DEFAULT_MAX_REPLANS,
    DEFAULT_MAX_SUBGOALS,
    Alarm,
    EpisodeLog,
    SubgoalRecord,
    run_plan_loop,
)
from code_as_monitor.core.constraints import Action, Constraint, Phase, Subgoal
from code_as_monitor.core.observation import Observation
from code_as_monitor.core.policy import Policy
from code_as_monitor.core.registry import Choice, check_positive

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


class CheckingAgent:
    """Inner-Monologue-style (``period_s=None``) or DoReMi-style (``period_s=k``) closed loop.

    Args:
        planner: ``next_subgoal(instruction, images, objects, previous, feedback) -> Subgoal``.
        vqa: :class:`~code_as_monitor.baselines.vqa.VQA` (one image per question).
        period_s: seconds between checks during execution; None checks only when a subgoal ends.
        ask_all_at_end: at the end of a subgoal, ask every constraint (Inner Monologue) instead of
            only the ``upon`` ones (DoReMi, which has watched the ``during`` ones all along).
        on_frame: called with every rendered observation and a banner (for sample videos).
    """

    def __init__(self, planner: Any, vqa: Any, config: BaselineConfig, period_s: float | None,
                 ask_all_at_end: bool, time_limit_s: float | None = None, on_event: EventFn | None = None,
                 on_frame: FrameFn | None = None) -> None:
        self.planner = planner
        self.vqa = vqa
        self.cfg = config
        self.period_s = period_s
        self.ask_all_at_end = ask_all_at_end
        self.time_limit_s = time_limit_s
        self.emit = on_event or _noop
        self.on_frame = on_frame
        self.frames = 0

    def _out_of_time(self, env: Any) -> bool:
        return self.time_limit_s is not None and env.t >= self.time_limit_s

    def _observe(self, env: Any, banner: str = "") -> Observation:
        obs = env.observe()
        self.frames += 1
        if self.on_frame is not None:
            self.on_frame(obs, banner)
        return obs

    def run(self, instruction: str, env: Any, policy: Policy) -> EpisodeLog:
        last = {"obs": self._observe(env)}  # renders only what it uses: reuse the subgoal's last frame

        def run_subgoal(index: int, subgoal: Subgoal, obs: Observation, ep: EpisodeLog) -> SubgoalRecord:
            record, last["obs"] = self._run_subgoal(subgoal, env, policy, ep)
            return record

        return run_plan_loop(
            instruction, env, self.planner, observe=lambda: last["obs"], run_subgoal=run_subgoal,
            max_subgoals=self.cfg.max_subgoals, max_replans=self.cfg.max_replans,
            out_of_time=lambda: self._out_of_time(env), emit=self.emit,
        )

    def _ask(self, constraints: list[Constraint], obs: Observation, subgoal: Subgoal,
             ep: EpisodeLog) -> list[tuple[Constraint, Any]]:
        """Ask each constraint on ``obs``; returns the (constraint, answer) pairs answered "no"."""
        noes = []
        for c in constraints:
            ans = self.vqa.ask(c, obs)
            self.emit("vqa", t=obs.t, constraint_id=c.id, yes=ans.yes, reason=ans.reason)
            if not ans.yes:
                noes.append((c, ans))
        return noes

    def _alarm(self, ep: EpisodeLog, subgoal: Subgoal, c: Constraint, reason: str, t: float) -> None:
        alarm = Alarm(t, c.id, c.phase.value, bool(c.proactive), reason, subgoal.text)
        ep.alarms.append(alarm)
        self.emit("alarm", **alarm.to_dict())

    def _run_subgoal(self, subgoal: Subgoal, env: Any, policy: Policy,
                     ep: EpisodeLog) -> tuple[SubgoalRecord, Observation]:
        t0 = env.t
        skill = subgoal.action.skill if subgoal.action else ""
        during = [c for c in subgoal.constraints if c.phase is Phase.DURING]
        upon = [c for c in subgoal.constraints if c.phase is Phase.UPON]

        def rec(outcome: str, reason: str) -> SubgoalRecord:
            return SubgoalRecord(subgoal.text, skill, outcome, reason, t0, env.t)

        policy.start(subgoal.action)  # type: ignore[arg-type]
        self.emit("policy_start", t=env.t, action=subgoal.action.to_dict() if subgoal.action else None)
        next_check = env.t + self.period_s if self.period_s else float("inf")
        while not policy.done:
            policy.step()
            if self._out_of_time(env):  # no halt: running out of time is not a decision to stop
                return rec("timeout", "time limit reached during the subgoal"), self._observe(env)
            if env.t + 1e-9 < next_check or policy.done:
                continue
            next_check += self.period_s or 0.0
            obs = self._observe(env)
            bad = self._ask(during, obs, subgoal, ep)
            if bad:
                c, ans = bad[0]
                self._alarm(ep, subgoal, c, ans.reason, obs.t)
                policy.halt()
                return rec("violated", f"{c.id}: {ans.reason}"), obs
            if upon and not self._ask(upon, obs, subgoal, ep):
                policy.halt()
                self.emit("early_halt", t=env.t, reason="all upon constraints answered yes")
                return rec("success", "all upon constraints answered yes"), obs
        obs = self._observe(env, "subgoal end")
        bad = self._ask(subgoal.constraints if self.ask_all_at_end else upon, obs, subgoal, ep)
        if bad:
            c, ans = bad[0]
            self._alarm(ep, subgoal, c, ans.reason, obs.t)
            return rec("reactive_failure", f"{c.id}: {ans.reason}"), obs
        return rec("success", "policy finished; the success detector said yes"), obs


__all__ = [
    "BaselineConfig",
    "CheckingAgent",
    "DoReMiConfig",
    "InnerMonologueConfig",
    "OpenLoopAgent",
    "OpenLoopConfig",
]
