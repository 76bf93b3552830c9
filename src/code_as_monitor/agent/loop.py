"""Code-as-Monitor around a policy in one call: :class:`Agent` wires the stages into a
:class:`~code_as_monitor.agent.monitor.Monitor` and drives it with
:func:`~code_as_monitor.agent.drive.drive`.

Kept for callers that hold their own stages (tests with fakes, notebooks); the streaming API is
:class:`~code_as_monitor.agent.monitor.Monitor`. The agent knows nothing of the simulator: it sees an
:class:`~code_as_monitor.agent.drive.Environment` and a :class:`~code_as_monitor.core.policy.Policy`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from code_as_monitor.agent.code_checker import CodeChecker, FrameFn, PromptFn
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.drive import Environment, drive
from code_as_monitor.agent.monitor import EventFn, Monitor
from code_as_monitor.agent.records import (
    DEFAULT_MAX_REPLANS,
    DEFAULT_MAX_SUBGOALS,
    SUCCESS_FEEDBACK,
    Alarm,
    EpisodeLog,
    SubgoalRecord,
)
from code_as_monitor.core.policy import Policy


class Agent:
    """Closes the loop around a policy.

    Args:
        planner: ``next_subgoal(instruction, images, objects, previous, feedback) -> Subgoal``.
        coder: ``write_program(subgoal, elements, images, check, max_retries) -> str``.
        painter: :class:`~code_as_monitor.painter.Painter`.
        tracker: ``reset(obs, elements)``, ``step(obs) -> TrackResult``, ``set_reacquire(fn)``.
        runtime: a monitor runtime (``start``/``step``/``close``; the caller closes it).
        history_factory: builds an element history with ``push(t, points)``/``arrays()``.
        on_event: ``fn(kind, **fields)`` for the event log (flushed by the caller's writer).
        on_frame: called every monitored frame (for videos and live views).
    """

    def __init__(self, planner: Any, coder: Any, painter: Any, tracker: Any, runtime: Any,
                 history_factory: Callable[[int], Any], config: AgentConfig | None = None,
                 on_event: EventFn | None = None, on_frame: FrameFn | None = None,
                 on_prompt: PromptFn | None = None) -> None:
        self.cfg = config or AgentConfig()
        self.planner = planner
        self.checker = CodeChecker(coder, painter, tracker, runtime, history_factory, self.cfg,
                                   on_frame=on_frame, on_prompt=on_prompt)
        self.on_event = on_event

    @property
    def tracker(self) -> Any:
        return self.checker.tracker

    @property
    def painter(self) -> Any:
        return self.checker.painter

    def monitor(self) -> Monitor:
        """A fresh streaming monitor over this agent's stages."""
        return Monitor(self.planner, self.checker, max_replans=self.cfg.max_replans,
                       max_subgoals=self.cfg.max_subgoals, max_same_start=self.cfg.max_same_start,
                       rest=self.cfg.rest_wait(),
                       time_limit_s=self.cfg.time_limit_s, on_event=self.on_event)

    def run(self, instruction: str, env: Environment, policy: Policy) -> EpisodeLog:
        """Run the task until the planner says it is complete, replans run out, or time is up."""
        return drive(self.monitor(), instruction, env, policy)


__all__ = [
    "DEFAULT_MAX_REPLANS",
    "DEFAULT_MAX_SUBGOALS",
    "SUCCESS_FEEDBACK",
    "Agent",
    "AgentConfig",
    "Alarm",
    "Environment",
    "EpisodeLog",
    "SubgoalRecord",
]
