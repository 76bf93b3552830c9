"""What a per-subgoal checker is and what it may use of the monitor (:mod:`code_as_monitor.agent.monitor`).

:class:`SubgoalChecker` is the per-subgoal part of a method (Code-as-Monitor's
:class:`~code_as_monitor.agent.code_checker.CodeChecker`, or a baseline's); it ends a subgoal with a
:class:`SubgoalEnd` and reaches the monitor only through a :class:`MonitorContext`. The monitor and the checkers
both import this module, and it imports neither, so they form no import circle.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from code_as_monitor.agent.records import Alarm, EpisodeLog
from code_as_monitor.core.constraints import Subgoal
from code_as_monitor.core.observation import Observation

if TYPE_CHECKING:
    from code_as_monitor.agent.monitor import Monitor


@dataclass
class SubgoalEnd:
    """A checker's verdict that the current subgoal is over: its outcome, reason, and whether the
    policy must be halted (it is still moving)."""

    outcome: str
    reason: str
    halt: bool = False
    code_attempts: int = 0


class SubgoalChecker(Protocol):
    """The per-subgoal part of a method (Code-as-Monitor's, or a baseline's).

    Optional: ``holding(obs) -> bool``, whether the robot holds one of the watched objects when a subgoal ends in
    failure (the monitor then re-plans without waiting for the scene to rest); a checker without it is taken to say
    no. Optional, together: ``follow(obs)`` and ``at_rest(obs, ctx) -> SubgoalEnd | None``, for the check before the
    task is called complete (the monitor waits for rest, handing each frame to ``follow``, then asks ``at_rest``
    whether the last subgoal still holds; None: it does); a checker without ``at_rest`` is taken at the planner's
    word."""

    def start_episode(self, obs: Observation) -> None:
        """Called with the episode's first observation (the one the first subgoal is planned on)."""

    def begin(self, index: int, subgoal: Subgoal, obs: Observation, ctx: MonitorContext) -> SubgoalEnd | None:
        """Prepare to watch ``subgoal`` from ``obs``; a :class:`SubgoalEnd` ends it before it starts."""

    def frame_due(self, t: float, policy_done: bool) -> bool:
        """Whether the checker wants a frame at time ``t`` (frames in between are skipped)."""

    def frame(self, obs: Observation, policy_done: bool, ctx: MonitorContext) -> SubgoalEnd | None:
        """Judge one due frame; None: the subgoal goes on."""

    def close(self) -> None:
        """Release workers and files."""


class MonitorContext:
    """What a checker may use of the monitor: events, alarms, the episode log, the time limit."""

    def __init__(self, monitor: Monitor) -> None:
        self._m = monitor

    @property
    def episode(self) -> EpisodeLog:
        return self._m.episode

    def emit(self, kind: str, **fields: Any) -> None:
        self._m.emit(kind, **fields)

    def out_of_time(self, t: float) -> bool:
        limit = self._m.time_limit_s
        return limit is not None and t >= limit

    def alarm(self, subgoal: Subgoal, constraint_id: str, phase: str, reason: str, t: float) -> Alarm:
        """Record and emit an alarm on ``constraint_id`` (proactive when its constraint is)."""
        c = next((c for c in subgoal.constraints if c.id == constraint_id), None)
        objects = sorted({p.obj for p in c.parts}) if c is not None else []
        a = Alarm(t, constraint_id, phase, bool(c and c.proactive), reason, subgoal.text, objects)
        self._m.episode.alarms.append(a)
        self._m._frame_alarms.append(a)
        self.emit("alarm", **a.to_dict())
        return a


def runs_to_end(subgoal: Subgoal, skills: Collection[str]) -> bool:
    """Whether ``subgoal``'s skill is one of ``skills``, which run to their end: a checker does not end such a subgoal
    before its policy finishes because its upon checks hold (:attr:`AgentConfig.run_to_end
    <code_as_monitor.agent.config.AgentConfig.run_to_end>`); a violation still halts it."""
    return subgoal.action is not None and subgoal.action.skill in skills


__all__ = ["MonitorContext", "SubgoalChecker", "SubgoalEnd", "runs_to_end"]
