"""The streaming closed loop: ``Monitor.start(instruction)``, ``Monitor.step(observation) -> Decision``.

One object drives every closed-loop method, in the simulator and on a robot: the planner proposes a
subgoal from the observation, the previous subgoal and the feedback (paper eq. 1); a per-subgoal
:class:`SubgoalChecker` watches it frame by frame (Code-as-Monitor's painted elements, generated
program, tracker and sandbox; or a baseline's yes/no questions); the subgoal's outcome becomes the
next feedback (``"success"`` or ``"failure: <reason>"``). The monitor stops when the planner says the
task is complete, after ``max_replans`` failed subgoals, after ``max_subgoals`` subgoals, at the
time limit, or when it is stuck: the planner proposed the same subgoal ``max_same_start`` times on one
observation and it could not start each time (nothing moved in between, so nothing would change).
After a halt or a failed subgoal the monitor re-plans once the scene has come to rest
(:class:`~code_as_monitor.agent.rest.RestWait`: the depth images stop changing, at most ``max_s``): the
halting decision then carries no action, and a later frame's ``start`` decision carries the re-planned one.
When the planner calls the task complete after a subgoal that succeeded, the checker (if it has ``follow`` and
``at_rest``) judges that subgoal's upon checks again once the scene is at rest: a violation is re-planned on.

The caller owns the policy and the clock. Each frame it hands over an
:class:`~code_as_monitor.core.observation.Observation` and whether the policy has finished its
current action; the :class:`~code_as_monitor.agent.decision.Decision` says whether to halt, which
action to start, and whether the episode is over. Nothing here imports the simulator.

    monitor = Monitor.from_config(MonitorConfig(backend="kb", segmenter="color", tracker="depth"))
    monitor.start("stack the blocks: red at the bottom, then green, then blue")
    while True:
        obs = robot.observe()                          # multi-view RGB-D + robot state, robot clock
        d = monitor.step(obs, policy_done=policy.done)
        if d.halt:
            policy.halt()
        if d.action is not None:
            policy.start(d.action)
        if d.finished:
            break
        policy.step()                                  # or let the robot's own controller run
    monitor.close()
"""

from __future__ import annotations

import json
import logging
import math
import numbers
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from code_as_monitor.agent.decision import Decision, DecisionKind
from code_as_monitor.agent.records import (
    DEFAULT_MAX_REPLANS,
    DEFAULT_MAX_SAME_START,
    DEFAULT_MAX_SUBGOALS,
    SUCCESS_FEEDBACK,
    Alarm,
    EpisodeLog,
    SubgoalRecord,
)
from code_as_monitor.agent.rest import NO_WAIT, RestWait, RestWatch
from code_as_monitor.agent.subgoal import MonitorContext, SubgoalChecker, SubgoalEnd
from code_as_monitor.core.constraints import Subgoal
from code_as_monitor.core.errors import ConfigError, ObservationError, VLMError
from code_as_monitor.core.observation import Observation, check_observation

if TYPE_CHECKING:
    from code_as_monitor.agent.config import MonitorConfig

log = logging.getLogger(__name__)

EventFn = Callable[..., Any]


def _noop_event(kind: str, **fields: Any) -> None:
    return None


class Monitor:
    """The closed loop as a streaming object (see the module docstring).

    Args:
        planner: ``next_subgoal(instruction, images, objects, previous, feedback) -> Subgoal``.
        checker: the method's :class:`SubgoalChecker`.
        max_replans: failed subgoals allowed before giving up.
        max_subgoals: subgoals allowed per episode.
        max_same_start: proposals of one identical subgoal that could not start, on one observation, after
            which the episode stops as stuck.
        time_limit_s: no new subgoal is planned at or after this time (observation seconds); None: none.
        cameras: view names to use; None: every view of the observation.
        rest: when to re-plan after a failure (:class:`~code_as_monitor.agent.rest.RestWait`); None: at once.
        check_done_at_rest: judge the last subgoal's upon checks again at rest before calling the task complete.
        on_event: ``fn(kind, **fields)`` for the event log.
        usage: the planner's token meter (``calls``, ``episode()``), reported by :attr:`usage`.
        owned: objects closed by :meth:`close` (the sandbox runtime of :meth:`from_config`).
    """

    def __init__(self, planner: Any, checker: SubgoalChecker, *, max_replans: int = DEFAULT_MAX_REPLANS,
                 max_subgoals: int = DEFAULT_MAX_SUBGOALS, max_same_start: int = DEFAULT_MAX_SAME_START,
                 time_limit_s: float | None = None, rest: RestWait | None = None, check_done_at_rest: bool = True,
                 cameras: list[str] | None = None, on_event: EventFn | None = None, usage: Any = None,
                 owned: list[Any] | None = None) -> None:
        if max_replans < 0:
            raise ConfigError(f"Monitor: max_replans must be >= 0, got {max_replans!r}")
        if max_subgoals < 1:
            raise ConfigError(f"Monitor: max_subgoals must be >= 1, got {max_subgoals!r}")
        if max_same_start < 1:
            raise ConfigError(f"Monitor: max_same_start must be >= 1, got {max_same_start!r}")
        self.planner = planner
        self.checker = checker
        self.max_replans = max_replans
        self.max_subgoals = max_subgoals
        self.max_same_start = max_same_start
        self.time_limit_s = time_limit_s
        self.rest = rest if rest is not None else NO_WAIT
        self.check_done_at_rest = check_done_at_rest
        self.cameras = list(cameras) if cameras else None
        self.emit: EventFn = on_event or _noop_event
        self.usage = usage
        self._owned = list(owned or [])
        self._ctx = MonitorContext(self)
        self.episode = EpisodeLog("")
        self._state = "idle"  # idle -> plan -> run -> (rest ->) plan -> ... -> (done-rest ->) over
        self._waiting: RestWatch | None = None  # the wait for rest under way (states rest and done-rest)
        self._frame_alarms: list[Alarm] = []
        self._subgoal: Subgoal | None = None
        self._previous: Subgoal | None = None
        self._feedback: str | None = None
        self._index = 0
        self._last_t: float | None = None

    @classmethod
    def from_config(cls, config: MonitorConfig, on_event: EventFn | None = None, on_frame: Any = None,
                    on_prompt: Any = None, backend: Any = None, skills: dict[str, str] | None = None) -> Monitor:
        """Build Code-as-Monitor from a :class:`~code_as_monitor.agent.config.MonitorConfig` (VLM backend,
        segmenter, tracker, cameras, rates): the stages come from :func:`~code_as_monitor.agent.build.build_stages`
        (``backend``: an already built backend to use instead of ``config.backend``; ``skills``: the policy's
        skills, name -> description, for the planner). The monitor owns the sandbox runtime's worker; call
        :meth:`close`."""
        from code_as_monitor.agent.build import build_stages

        stages = build_stages(config, on_frame=on_frame, on_prompt=on_prompt, backend=backend, skills=skills)
        return cls(stages.planner, stages.checker, max_replans=config.max_replans, max_subgoals=config.max_subgoals,
                   max_same_start=config.max_same_start, time_limit_s=config.time_limit_s,
                   rest=config.rest_wait(), check_done_at_rest=config.check_done_at_rest, cameras=config.cameras,
                   on_event=on_event, usage=stages.planner.usage, owned=[stages.runtime])

    # ------------------------------------------------------------------------------------------------
    @property
    def subgoal(self) -> Subgoal | None:
        """The subgoal being watched (None between subgoals and once the episode is over)."""
        return self._subgoal if self._state == "run" else None

    @property
    def finished(self) -> bool:
        return self._state == "over"

    def start(self, instruction: str) -> None:
        """Begin an episode for ``instruction``; the first :meth:`step` plans the first subgoal."""
        if not isinstance(instruction, str) or not instruction.strip():
            raise ConfigError(f"Monitor.start: the instruction must be a non-empty string, got {instruction!r}")
        self.episode = EpisodeLog(instruction)
        self._state = "plan"
        self._subgoal = self._previous = None
        self._waiting = None
        self._feedback = None
        self._index = 0
        self._last_t = None

    def frame_due(self, t: float, policy_done: bool = False) -> bool:
        """Whether :meth:`step` would judge a frame taken at ``t`` (a caller whose frames are expensive
        asks before rendering). Between subgoals every frame is due; after the episode none is."""
        if isinstance(t, bool) or not isinstance(t, numbers.Real) or not math.isfinite(t):
            raise ObservationError(f"Monitor.frame_due: t must be a finite number of seconds, got {t!r}")
        if self._state == "run":
            return self.checker.frame_due(t, policy_done)
        if self._state in ("rest", "done-rest") and self._waiting is not None:
            return self._waiting.due(t)
        return self._state == "plan"

    def step(self, obs: Observation, policy_done: bool = False) -> Decision:
        """Take one observation; returns what the control loop must do (see :class:`Decision`).

        ``policy_done``: the policy has finished its current action by itself (its ``upon`` checks
        are then judged; without it, a subgoal ends only on a violation or on its upon checks).
        A frame that is not due (the monitoring rate is lower than the camera's) returns ``continue``
        without being looked at.
        """
        if self._state == "idle":
            raise ConfigError("Monitor.step called before Monitor.start(instruction)")
        if self._state == "over":
            raise ConfigError("Monitor.step called after the episode ended; call start() for a new one")
        check_observation(obs)
        obs = self._select_views(obs)
        if self._last_t is not None and obs.t < self._last_t:
            raise ObservationError(f"observation time went backwards: {obs.t!r} after {self._last_t!r}")
        if self._last_t is None:
            self.emit("episode_start", t=obs.t, instruction=self.episode.instruction)
            self.checker.start_episode(obs)
        self._last_t = obs.t
        self._frame_alarms = []
        if self._state == "plan":
            return self._plan(obs, DecisionKind.START, halt=False, ended=None)
        if self._state in ("rest", "done-rest"):
            return self._rest_step(obs)
        if not self.checker.frame_due(obs.t, policy_done):
            return Decision(DecisionKind.CONTINUE, obs.t, subgoal=self._subgoal)
        end = self.checker.frame(obs, policy_done, self._ctx)
        if end is None:
            return Decision(DecisionKind.CONTINUE, obs.t, subgoal=self._subgoal)
        record = self._end_subgoal(end, obs.t)
        kind = (DecisionKind.SUBGOAL_DONE if end.outcome == "success"
                else DecisionKind.HALT if end.outcome == "violated" else DecisionKind.SUBGOAL_FAILED)
        if self._state == "over":
            return self._over(obs.t, halt=end.halt, ended=record)
        wait = end.outcome != "success" and self.rest.enabled
        if wait and self._holding(obs):
            self.emit("rest", t=obs.t, waited_s=0.0, at_rest=False, skipped="an object is in hand")
        elif wait:
            self._wait_for_rest(obs, "rest")
            return Decision(kind, obs.t, halt=end.halt, violations=list(self._frame_alarms), ended=record,
                            reason=record.reason)
        return self._plan(obs, kind, halt=end.halt, ended=record)

    def stop(self, reason: str, t: float | None = None) -> Decision:
        """End the episode from outside (the recording ended, an operator stopped the robot); the
        subgoal under way, if any, is left without an outcome. Returns the final ``stopped`` decision."""
        if self._state in ("idle", "over"):
            raise ConfigError(f"Monitor.stop called while no episode is under way (state {self._state!r})")
        self.episode.stop_reason = reason
        t_end = t if t is not None else (self._last_t if self._last_t is not None else 0.0)
        self._frame_alarms = []
        return self._over(t_end, halt=False, ended=None)

    def close(self) -> None:
        """Release the checker's and the runtime's workers (idempotent)."""
        self.checker.close()
        for o in self._owned:
            o.close()
        self._owned = []

    def __enter__(self) -> Monitor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------------------------------------
    def _wait_for_rest(self, obs: Observation, state: str) -> None:
        self._state, self._subgoal = state, None
        self._waiting = RestWatch(self.rest, obs)

    def _select_views(self, obs: Observation) -> Observation:
        if self.cameras is None:
            return obs
        missing = [c for c in self.cameras if c not in obs.views]
        if missing:
            raise ObservationError(f"observation at t={obs.t} has no view {missing[0]!r}; it has {sorted(obs.views)}")
        return replace(obs, views={c: obs.views[c] for c in self.cameras})

    def _holding(self, obs: Observation) -> bool:
        """Whether the checker sees the robot holding an object (then the re-plan does not wait: see
        :mod:`~code_as_monitor.agent.rest`); a checker that cannot tell says no."""
        holding = getattr(self.checker, "holding", None)
        return bool(holding(obs)) if callable(holding) else False

    def _rest_step(self, obs: Observation) -> Decision:
        """A frame while waiting for the scene to come to rest: re-plan on it once it is (or at ``max_s``)."""
        w = self._waiting
        assert w is not None
        if not w.due(obs.t):
            return Decision(DecisionKind.CONTINUE, obs.t)
        done = self._state == "done-rest"
        if not w.observe(obs):
            if done:
                self.checker.follow(obs)  # type: ignore[attr-defined]
            return Decision(DecisionKind.CONTINUE, obs.t)
        self.emit("done_rest" if done else "rest", t=obs.t, waited_s=round(w.waited, 4), at_rest=w.at_rest)
        self._waiting = None
        self._state = "plan"
        if not done:
            return self._plan(obs, DecisionKind.START, halt=False, ended=None)
        # unmoved since the claim, it is the scene the completion was judged on: again would re-sample the noise
        end = self.checker.at_rest(obs, self._ctx) if w.moved else None  # type: ignore[attr-defined]
        if end is None:
            return self._complete(obs.t, halt=False, ended=None)
        self._subgoal = self._previous
        record = self._end_subgoal(end, obs.t)  # the last subgoal again, failed on the resting scene
        return self._over(obs.t, halt=False, ended=record) if self._state == "over" \
            else self._plan(obs, DecisionKind.SUBGOAL_FAILED, halt=False, ended=record)

    def _complete(self, t: float, halt: bool, ended: SubgoalRecord | None) -> Decision:
        self.episode.finished, self.episode.stop_reason = True, "planner: task complete"
        self.emit("task_complete", t=t)
        return self._over(t, halt=halt, ended=ended, kind=DecisionKind.TASK_DONE)

    def _plan(self, obs: Observation, kind: DecisionKind, halt: bool, ended: SubgoalRecord | None) -> Decision:
        """Plan subgoals on ``obs`` until one starts (or the episode ends)."""
        ep = self.episode
        not_started: dict[str, int] = {}  # subgoal (as JSON) -> times it could not start on this observation
        while True:
            if self._index >= self.max_subgoals:
                ep.stop_reason = f"subgoal bound ({self.max_subgoals}) reached"
                return self._over(obs.t, halt=halt, ended=ended)
            if self._ctx.out_of_time(obs.t):
                ep.stop_reason = "time limit"
                return self._over(obs.t, halt=halt, ended=ended)
            images = {n: v.rgb for n, v in obs.views.items()}
            try:
                subgoal = self.planner.next_subgoal(ep.instruction, images, obs.objects, self._previous,
                                                    self._feedback)
            except VLMError as exc:
                ep.stop_reason = f"planner failed: {exc}"
                ep.error = str(exc)
                self.emit("planner_error", t=obs.t, error=str(exc))
                return self._over(obs.t, halt=halt, ended=ended)
            if subgoal.done:
                if not (self.check_done_at_rest and self.rest.enabled and self._feedback == SUCCESS_FEEDBACK
                        and callable(getattr(self.checker, "at_rest", None))):
                    return self._complete(obs.t, halt, ended)
                self.emit("task_complete_claimed", t=obs.t, checking="the last subgoal's upon checks at rest")
                self._wait_for_rest(obs, "done-rest")
                return Decision(kind, obs.t, halt=halt, violations=list(self._frame_alarms), ended=ended,
                                reason=ended.reason if ended is not None else "")
            self.emit("subgoal", t=obs.t, index=self._index, subgoal=subgoal.to_dict())
            self._subgoal = subgoal
            self._t0 = obs.t
            early = self.checker.begin(self._index, subgoal, obs, self._ctx)
            if early is not None:
                ended = self._end_subgoal(early, obs.t)
                kind = DecisionKind.SUBGOAL_FAILED
                if self._state != "over":
                    key = json.dumps(subgoal.to_dict(), sort_keys=True, default=str)
                    not_started[key] = not_started.get(key, 0) + 1
                    if not_started[key] >= self.max_same_start:
                        ep.stop_reason = (f"stuck: the planner proposed {subgoal.text!r} {not_started[key]} times "
                                          f"on the observation at t={obs.t:.3f} s and it could not start "
                                          f"({early.reason})")
                        self.emit("stuck", t=obs.t, subgoal=subgoal.text, times=not_started[key],
                                  reason=early.reason)
                        self._state = "over"
                if self._state == "over":
                    return self._over(obs.t, halt=halt, ended=ended)
                continue
            self._state = "run"
            self.emit("policy_start", t=obs.t, action=subgoal.action.to_dict() if subgoal.action else None)
            return Decision(kind, obs.t, halt=halt, action=subgoal.action, subgoal=subgoal,
                            violations=list(self._frame_alarms), ended=ended,
                            reason=ended.reason if ended is not None else "")

    def _end_subgoal(self, end: SubgoalEnd, t: float) -> SubgoalRecord:
        """Record the subgoal's outcome and turn it into feedback; may end the episode."""
        sg = self._subgoal
        assert sg is not None
        ep = self.episode
        record = SubgoalRecord(sg.text, sg.action.skill if sg.action else "", end.outcome, end.reason,
                               self._t0, t, end.code_attempts)
        ep.subgoals.append(record)
        self.emit("subgoal_end", t=t, **record.to_dict())
        self._previous = sg
        self._index += 1
        self._state = "plan"
        if record.outcome == "success":
            self._feedback = SUCCESS_FEEDBACK  # the planner's success token; the reasons are in the log
        else:
            self._feedback = f"failure: {record.reason}"
            ep.replans += 1
            if ep.replans > self.max_replans:
                ep.stop_reason = f"too many re-plans ({ep.replans})"
                self._state = "over"
                return record
        if record.outcome == "timeout":
            ep.stop_reason = "time limit"
            self._state = "over"
        return record

    def _over(self, t: float, halt: bool, ended: SubgoalRecord | None,
              kind: DecisionKind = DecisionKind.STOPPED) -> Decision:
        ep = self.episode
        self._state = "over"
        ep.t_end = t
        self.emit("episode_end", t=t, finished=ep.finished, stop_reason=ep.stop_reason, replans=ep.replans)
        return Decision(kind, t, halt=halt, violations=list(self._frame_alarms), ended=ended, reason=ep.stop_reason)


def build_monitor(config: MonitorConfig, on_event: EventFn | None = None, on_frame: Any = None,
                  on_prompt: Any = None, backend: Any = None, skills: dict[str, str] | None = None) -> Monitor:
    """:meth:`Monitor.from_config` as a function (the benchmark's and the bag replay's callers)."""
    return Monitor.from_config(config, on_event=on_event, on_frame=on_frame, on_prompt=on_prompt, backend=backend,
                               skills=skills)


__all__ = ["Monitor", "MonitorContext", "SubgoalChecker", "SubgoalEnd", "build_monitor"]
