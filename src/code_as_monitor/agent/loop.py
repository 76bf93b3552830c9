"""The closed loop: planner + painter + monitor around any open-loop policy.

Per subgoal: plan (VLM call 1) -> paint elements -> write monitor code (VLM call 2, plus bounded
regenerations on validation/coverage errors) -> start the policy. Every frame: track elements,
evaluate every check in the sandbox. A violated ``during`` check halts the policy and its reason
becomes the planner's feedback; all ``upon`` checks satisfied completes the subgoal (halting a
still-moving policy early); a policy that finishes with an ``upon`` check false is a reactive failure.
The agent knows nothing of the simulator: it sees an :class:`Environment` and a
:class:`~code_as_monitor.core.policy.Policy`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from code_as_monitor.core.constraints import Phase, Subgoal, Verdict
from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import ConfigError, PerceptionError, ProgramError, VLMError
from code_as_monitor.core.observation import Observation
from code_as_monitor.core.policy import Policy

log = logging.getLogger(__name__)

SUCCESS_FEEDBACK = "success"
"""Feedback after a completed subgoal (the same token as ``vlm.schemas.SUCCESS_FEEDBACK``)."""

DEFAULT_MAX_REPLANS = 30
"""Failed subgoals allowed per episode: one bound for every method (CaM and the baselines)."""
DEFAULT_MAX_SUBGOALS = 80
"""Subgoals allowed per episode; the task's time limit is normally what ends an episode."""


class Environment(Protocol):
    """What the agent needs from the world (a simulator or a robot driver)."""

    @property
    def t(self) -> float:
        """Current time, seconds (sim time in the simulator)."""
        ...

    def observe(self) -> Observation:
        """Render/grab one multi-view RGB-D frame."""
        ...


@dataclass
class AgentConfig:
    """Closed-loop settings.

    Attributes:
        frame_hz: monitoring rate (frames per second of environment time).
        max_replans: failed subgoals allowed before giving up.
        max_subgoals: hard bound on subgoals per episode.
        time_limit_s: episode time limit (environment seconds); None for none.
        history_len: frames of element history fed to the program as H.
        code_retries: regenerations allowed when validation or path coverage fails.
        halt_on_upon: halt a still-moving policy as soon as every upon check holds.
        upon_dwell_frames: consecutive frames the upon checks must hold before completing.
        refresh_on_done: when the policy finishes, re-measure the elements before judging the upon
            checks, so tracker drift accumulated during the motion does not decide the outcome: an element
            the tracker saw move more than ``refresh_motion`` during the subgoal (the carried object) is
            re-painted from the current, static frame; one it saw at rest keeps its measurement from the
            subgoal start, when it was painted unoccluded (re-painting it now would measure whatever is
            left visible, e.g. the sides of a block another block now covers). Robot elements follow
            forward kinematics either way.
        refresh_motion: metres of tracked centroid motion over the subgoal above which an element counts
            as moved.
        settle_frames: when the policy has finished but an upon check has no verdict (a program fault,
            or a stale element), wait up to this many frames for one before calling it a failure.
    """

    frame_hz: float = 10.0
    max_replans: int = DEFAULT_MAX_REPLANS
    max_subgoals: int = DEFAULT_MAX_SUBGOALS
    time_limit_s: float | None = None
    history_len: int = 64
    code_retries: int = 2
    halt_on_upon: bool = True
    upon_dwell_frames: int = 2
    refresh_on_done: bool = True
    refresh_motion: float = 0.03
    settle_frames: int = 5

    def __post_init__(self) -> None:
        if self.frame_hz <= 0:
            raise ConfigError(f"AgentConfig.frame_hz must be > 0, got {self.frame_hz!r}")
        if self.max_replans < 0:
            raise ConfigError(f"AgentConfig.max_replans must be >= 0, got {self.max_replans!r}")
        if self.history_len < 2:
            raise ConfigError(f"AgentConfig.history_len must be >= 2, got {self.history_len!r}")


@dataclass
class Alarm:
    """A violation the monitor raised (what the benchmark scores against ground truth)."""

    t: float
    constraint_id: str
    phase: str
    proactive: bool
    reason: str
    subgoal: str

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


@dataclass
class SubgoalRecord:
    text: str
    skill: str
    outcome: str  # "success" | "violated" | "reactive_failure" | "timeout" | "error"
    reason: str
    t_start: float
    t_end: float
    code_attempts: int = 0

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


@dataclass
class EpisodeLog:
    """What happened in one closed-loop episode."""

    instruction: str
    subgoals: list[SubgoalRecord] = field(default_factory=list)
    alarms: list[Alarm] = field(default_factory=list)
    finished: bool = False  # the planner said the task is complete
    stop_reason: str = ""
    t_end: float = 0.0
    replans: int = 0
    programs: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "instruction": self.instruction,
            "subgoals": [s.to_dict() for s in self.subgoals],
            "alarms": [a.to_dict() for a in self.alarms],
            "finished": self.finished,
            "stop_reason": self.stop_reason,
            "t_end": self.t_end,
            "replans": self.replans,
        }


EventFn = Callable[..., Any]
FrameFn = Callable[[Observation, list[Element], dict[int, np.ndarray], list[Verdict], str], None]


def _noop_event(kind: str, **fields: Any) -> None:
    return None


class Agent:
    """Closes the loop around a policy.

    Args:
        planner: ``next_subgoal(instruction, images, objects, previous, feedback) -> Subgoal``.
        coder: ``write_program(subgoal, elements, images, check, max_retries, feedback) -> str``.
        painter: :class:`~code_as_monitor.painter.Painter`.
        tracker: ``reset(obs, elements)``, ``step(obs) -> TrackResult``, ``set_reacquire(fn)``.
        runtime_factory: builds a monitor runtime (``start``/``step``/``close``).
        history_factory: builds an element history with ``push(t, points)``/``arrays()``.
        on_event: ``fn(kind, **fields)`` for the event log (flushed by the caller's writer).
        on_frame: called every monitored frame (for videos and live views).
    """

    def __init__(
        self,
        planner: Any,
        coder: Any,
        painter: Any,
        tracker: Any,
        runtime: Any,
        history_factory: Callable[[int], Any],
        config: AgentConfig | None = None,
        on_event: EventFn | None = None,
        on_frame: FrameFn | None = None,
        on_prompt: Callable[[int, Subgoal, dict[str, np.ndarray], str], None] | None = None,
    ) -> None:
        self.planner = planner
        self.coder = coder
        self.painter = painter
        self.tracker = tracker
        self.runtime = runtime
        self.history_factory = history_factory
        self.cfg = config or AgentConfig()
        self.emit = on_event or _noop_event
        self.on_frame = on_frame
        self.on_prompt = on_prompt
        self._verdict_state: dict[str, str] = {}  # constraint id -> "ok" | "violated" | "fault"

    # ------------------------------------------------------------------------------------------
    def run(self, instruction: str, env: Environment, policy: Policy) -> EpisodeLog:
        """Run the task until the planner says it is complete, replans run out, or time is up."""
        return run_plan_loop(
            instruction, env, self.planner, observe=env.observe,
            run_subgoal=lambda i, sg, obs, ep: self._run_subgoal(i, sg, obs, env, policy, ep),
            max_subgoals=self.cfg.max_subgoals, max_replans=self.cfg.max_replans,
            out_of_time=lambda: self._out_of_time(env), emit=self.emit,
        )

    # ------------------------------------------------------------------------------------------
    def _out_of_time(self, env: Environment) -> bool:
        return self.cfg.time_limit_s is not None and env.t >= self.cfg.time_limit_s

    def _run_subgoal(
        self, index: int, subgoal: Subgoal, obs: Observation, env: Environment, policy: Policy, ep: EpisodeLog
    ) -> SubgoalRecord:
        t0 = env.t
        skill = subgoal.action.skill if subgoal.action else ""

        def rec(outcome: str, reason: str, attempts: int = 0) -> SubgoalRecord:
            return SubgoalRecord(subgoal.text, skill, outcome, reason, t0, env.t, attempts)

        # Paint.
        painted = self.painter.paint(obs, subgoal)
        for m in painted.missing:
            self.emit("element_missing", t=env.t, spec=m.to_dict())
        self.emit("elements", t=env.t, legend=painted.legend(), seconds=painted.seconds)
        if painted.missing:
            names = ", ".join(f"{s.obj}/{s.part}" if s.part else s.obj for s in painted.missing)
            return rec("error", f"cannot see {names}")
        elements = painted.elements
        positions = {e.id: e.points for e in elements}
        history = self.history_factory(self.cfg.history_len)
        history.push(obs.t, positions)

        # Code, validated statically and by path coverage on the current state.
        attempts = {"n": 0}

        def check(source: str) -> None:
            attempts["n"] += 1
            H, ht = history.arrays()
            self.runtime.start(source, subgoal.constraints, positions, H, ht, obs.t)

        try:
            source = self.coder.write_program(
                subgoal, elements, painted.images, check=check, max_retries=self.cfg.code_retries
            )
        except (ProgramError, VLMError) as exc:
            self.emit("program_rejected", t=env.t, error=str(exc))
            return rec("error", f"no valid monitor program: {exc}", attempts["n"])
        ep.programs.append(source)
        self.emit("program", t=env.t, index=index, source=source, attempts=attempts["n"])
        if self.on_prompt is not None:
            self.on_prompt(index, subgoal, painted.images, source)

        # Execute and monitor.
        self.tracker.reset(obs, elements)
        self.tracker.set_reacquire(
            lambda o, el: self.painter.build_element(o, el.id, painted.specs[el.id])
        )
        period = 1.0 / self.cfg.frame_hz
        next_frame = env.t + period
        upon = subgoal.upon()
        upon_streak = 0
        self._verdict_state = {}
        uses = {c.id: set(c.element_ids) for c in subgoal.constraints}
        unknown_before: set[str] = set()
        policy.start(subgoal.action)  # type: ignore[arg-type]
        self.emit("policy_start", t=env.t, action=subgoal.action.to_dict() if subgoal.action else None)
        while True:
            policy.step()
            done = policy.done
            if env.t + 1e-9 < next_frame and not done:
                continue
            next_frame += period
            try:
                verdicts, view_state = self._monitor_frame(env, elements, history)
            except PerceptionError as exc:
                policy.halt()
                return rec("error", f"perception failed: {exc}", attempts["n"])
            # A check that reads a stale element (lost by the tracker, not yet re-acquired, or with
            # non-finite points) has no verdict this frame: it can neither raise an alarm nor complete
            # the subgoal.
            stale_ids = {i for i, st in view_state[2].stale.items() if np.any(st)}
            stale_ids |= set(getattr(self.runtime, "stale_elements", ()))  # NaN/inf points: as if lost
            unknown = {cid for cid, ids in uses.items() if ids & stale_ids}
            if unknown != unknown_before:
                self.emit("verdicts_unknown", t=env.t, constraints=sorted(unknown), stale_elements=sorted(stale_ids))
                unknown_before = unknown
            verdicts = [v for v in verdicts if v.constraint_id not in unknown]
            violated = [v for v in verdicts if v.phase is Phase.DURING and not v.ok and not v.fault]
            upon_v = [v for v in verdicts if v.phase is Phase.UPON and not v.fault]
            faults = [v for v in verdicts if v.fault]
            for v in faults:
                self.emit("program_fault", t=v.t, constraint_id=v.constraint_id, reason=v.reason)
            upon_ok = bool(upon) and len(upon_v) == len(upon) and all(v.ok for v in upon_v)
            upon_streak = upon_streak + 1 if upon_ok else 0
            banner = ""
            if violated:
                v = violated[0]
                banner = f"VIOLATION {v.constraint_id}: {v.reason}"
                self._alarm(ep, subgoal, v)
                policy.halt()
                self._frame(view_state, verdicts, banner)
                return rec("violated", f"{v.constraint_id}: {v.reason}", attempts["n"])
            if upon_ok and (done or (self.cfg.halt_on_upon and upon_streak >= self.cfg.upon_dwell_frames)):
                if not done:
                    policy.halt()
                    self.emit("early_halt", t=env.t, reason="all upon constraints satisfied")
                self._frame(view_state, verdicts, "subgoal complete")
                return rec("success", "; ".join(v.reason for v in upon_v), attempts["n"])
            self._frame(view_state, verdicts, banner)
            if done:
                upon_v = self._final_upon(env, policy, elements, painted, history, upon, uses)
                if not upon:
                    return rec("success", "policy finished", attempts["n"])
                if len(upon_v) == len(upon) and all(v.ok for v in upon_v):
                    return rec("success", "; ".join(v.reason for v in upon_v), attempts["n"])
                bad = [v for v in upon_v if not v.ok]
                v = bad[0] if bad else None
                reason = (f"{v.constraint_id}: {v.reason}" if v
                          else "no verdict on the upon checks (faults or lost elements)")
                if v is not None:
                    self._alarm(ep, subgoal, v)
                return rec("reactive_failure", reason, attempts["n"])
            if self._out_of_time(env):
                # Not a monitor decision: the episode ends here, the policy is not halted (a task that
                # scores "halted in time" must not count the clock running out as a halt).
                return rec("timeout", "time limit reached during the subgoal", attempts["n"])

    def _final_upon(
        self, env: Environment, policy: Policy, elements: list[Element], painted: Any, history: Any,
        upon: list[Any], uses: dict[str, set[int]],
    ) -> list[Verdict]:
        """Upon verdicts once the policy has finished: re-painted elements, a few frames to get a verdict."""
        period = 1.0 / self.cfg.frame_hz
        upon_ids = {c.id for c in upon}
        verdicts: list[Verdict] = []
        for attempt in range(self.cfg.settle_frames + 1):
            if attempt:
                t_next = env.t + period
                while env.t + 1e-9 < t_next:
                    policy.step()  # the policy is done: this holds the arm while time passes
            obs = env.observe()
            tr = self.tracker.step(obs)
            points = dict(tr.points)
            stale = {i: np.asarray(st) for i, st in tr.stale.items()}
            if self.cfg.refresh_on_done:
                H0, _ = history.arrays()
                for e in elements:
                    if e.owner[0] == "robot" or e.id not in H0:
                        continue
                    moved = np.linalg.norm(H0[e.id][-1].mean(axis=0) - H0[e.id][0].mean(axis=0))
                    if moved <= self.cfg.refresh_motion:
                        points[e.id] = e.points  # at rest all along: its measurement from the subgoal start
                        stale[e.id] = np.zeros(len(e.points), dtype=bool)
                        continue
                    fresh = self.painter.build_element(obs, e.id, painted.specs[e.id])
                    if fresh is not None and fresh.points.shape == points[e.id].shape:
                        points[e.id] = fresh.points
                        stale[e.id] = np.zeros(len(fresh.points), dtype=bool)
            history.push(obs.t, points)
            H, ht = history.arrays()
            stale_ids = {i for i, st in stale.items() if np.any(st)}
            verdicts = [
                v for v in self.runtime.step(points, H, ht, obs.t)
                if v.constraint_id in upon_ids and not v.fault and not (uses[v.constraint_id] & stale_ids)
            ]
            if len(verdicts) == len(upon_ids):
                break
        self.emit("final_check", t=env.t, verdicts=[v.to_dict() for v in verdicts],
                  refreshed=self.cfg.refresh_on_done)
        return verdicts

    def _monitor_frame(
        self, env: Environment, elements: list[Element], history: Any
    ) -> tuple[list[Verdict], tuple[Observation, list[Element], Any]]:
        """One monitored frame: observe, track, push the history, evaluate every check in the sandbox.

        Verdict events are written when a check's state (ok / violated / fault) changes, not every frame.
        """
        obs = env.observe()
        tr = self.tracker.step(obs)
        history.push(obs.t, tr.points)
        H, ht = history.arrays()
        verdicts = self.runtime.step(tr.points, H, ht, obs.t)
        for v in verdicts:
            state = "fault" if v.fault else ("ok" if v.ok else "violated")
            if self._verdict_state.get(v.constraint_id) != state:
                self._verdict_state[v.constraint_id] = state
                self.emit("verdict", **v.to_dict())
        return verdicts, (obs, elements, tr)

    def _frame(self, state: tuple[Observation, list[Element], Any], verdicts: list[Verdict], banner: str) -> None:
        """Hand the frame to ``on_frame`` (videos, live views) with the elements at their tracked positions."""
        if self.on_frame is None:
            return
        obs, elements, tr = state
        current = [Element(e.id, e.name, e.kind, tr.points.get(e.id, e.points), e.owner, e.color) for e in elements]
        self.on_frame(obs, current, tr.stale, verdicts, banner)

    def _alarm(self, ep: EpisodeLog, subgoal: Subgoal, v: Verdict) -> None:
        c = next((c for c in subgoal.constraints if c.id == v.constraint_id), None)
        alarm = Alarm(v.t, v.constraint_id, v.phase.value, bool(c and c.proactive), v.reason, subgoal.text)
        ep.alarms.append(alarm)
        self.emit("alarm", **alarm.to_dict())


def run_plan_loop(
    instruction: str,
    env: Environment,
    planner: Any,
    *,
    observe: Callable[[], Observation],
    run_subgoal: Callable[[int, Subgoal, Observation, EpisodeLog], SubgoalRecord],
    max_subgoals: int,
    max_replans: int,
    out_of_time: Callable[[], bool],
    emit: EventFn = _noop_event,
) -> EpisodeLog:
    """The episode loop every closed-loop method shares (paper eq. 1 in a loop).

    Ask the planner for the next subgoal from the observation, the previous subgoal and the feedback;
    run it with ``run_subgoal`` (the method: CaM's monitor, or a baseline's VQA checks); feed back
    ``"success"`` or ``"failure: <reason>"``; stop when the planner says the task is complete, after
    ``max_replans`` failed subgoals, at the time limit, or after ``max_subgoals``.
    """
    ep = EpisodeLog(instruction)
    previous: Subgoal | None = None
    feedback: str | None = None
    emit("episode_start", t=env.t, instruction=instruction)
    for index in range(max_subgoals):
        if out_of_time():
            ep.stop_reason = "time limit"
            break
        obs = observe()
        images = {n: v.rgb for n, v in obs.views.items()}
        try:
            subgoal = planner.next_subgoal(instruction, images, obs.objects, previous, feedback)
        except VLMError as exc:
            ep.stop_reason = f"planner failed: {exc}"
            emit("planner_error", t=env.t, error=str(exc))
            break
        if subgoal.done:
            ep.finished = True
            ep.stop_reason = "planner: task complete"
            emit("task_complete", t=env.t)
            break
        emit("subgoal", t=env.t, index=index, subgoal=subgoal.to_dict())
        record = run_subgoal(index, subgoal, obs, ep)
        ep.subgoals.append(record)
        emit("subgoal_end", t=env.t, **record.to_dict())
        previous = subgoal
        if record.outcome == "success":
            # The planner's success token; the upon reasons are in the event log.
            feedback = SUCCESS_FEEDBACK
        else:
            feedback = f"failure: {record.reason}"
            ep.replans += 1
            if ep.replans > max_replans:
                ep.stop_reason = f"too many re-plans ({ep.replans})"
                break
        if record.outcome == "timeout":
            ep.stop_reason = "time limit"
            break
    else:
        ep.stop_reason = f"subgoal bound ({max_subgoals}) reached"
    ep.t_end = env.t
    emit("episode_end", t=env.t, finished=ep.finished, stop_reason=ep.stop_reason, replans=ep.replans)
    return ep


__all__ = [
    "DEFAULT_MAX_REPLANS",
    "DEFAULT_MAX_SUBGOALS",
    "Agent",
    "AgentConfig",
    "Alarm",
    "Environment",
    "EpisodeLog",
    "SubgoalRecord",
    "run_plan_loop",
]
