"""What an episode leaves behind: alarms, per-subgoal records and the episode log (plain, JSON-ready).

Shared by every closed-loop method (Code-as-Monitor and the baselines), so the benchmark scores all
methods' detections the same way.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

SUCCESS_FEEDBACK = "success"
"""Feedback after a completed subgoal (the same token as ``vlm.schemas.SUCCESS_FEEDBACK``)."""

DEFAULT_MAX_REPLANS = 30
"""Failed subgoals allowed per episode: one bound for every method (CaM and the baselines)."""
DEFAULT_MAX_SUBGOALS = 80
"""Subgoals allowed per episode; the task's time limit is normally what ends an episode."""
DEFAULT_MAX_SAME_START = 3
"""Times one observation may see the planner propose the same subgoal that could not start (no valid
monitor program, an element it cannot see, a constraint already violated) before the episode stops as
stuck: nothing has moved in between, so a deterministic planner and coder would repeat it to the re-plan
bound; a sampling VLM gets two more tries."""


@dataclass
class Alarm:
    """A violation the monitor raised (what the benchmark scores against ground truth).

    Attributes:
        t: time of the frame that showed it, seconds.
        constraint_id, phase, proactive: the violated check (``phase`` is ``"during"`` or ``"upon"``).
        reason: the check's reason string.
        subgoal: the text of the subgoal it belonged to.
        objects: the objects the violated constraint is about (the owners of its elements, ``robot`` included):
            what the benchmark matches against a ground-truth failure's object.
    """

    t: float
    constraint_id: str
    phase: str
    proactive: bool
    reason: str
    subgoal: str
    objects: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


@dataclass
class SubgoalRecord:
    """How one subgoal ended.

    ``outcome``: ``success`` | ``violated`` (a during check failed; the policy was halted) |
    ``reactive_failure`` (the policy finished with an upon check false) | ``timeout`` | ``error``
    (elements not visible, no valid monitor program, perception failed).
    """

    text: str
    skill: str
    outcome: str
    reason: str
    t_start: float
    t_end: float
    code_attempts: int = 0

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


@dataclass
class EpisodeLog:
    """What happened in one closed-loop episode.

    ``finished``: the planner said the task is complete. ``error``: set when the episode stopped
    because the planner's backend failed (not a task failure: nothing was decided about the task).
    """

    instruction: str
    subgoals: list[SubgoalRecord] = field(default_factory=list)
    alarms: list[Alarm] = field(default_factory=list)
    finished: bool = False
    stop_reason: str = ""
    t_end: float = 0.0
    replans: int = 0
    programs: list[str] = field(default_factory=list)
    error: str | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "instruction": self.instruction,
            "subgoals": [s.to_dict() for s in self.subgoals],
            "alarms": [a.to_dict() for a in self.alarms],
            "finished": self.finished,
            "stop_reason": self.stop_reason,
            "t_end": self.t_end,
            "replans": self.replans,
            "error": self.error,
        }


__all__ = ["DEFAULT_MAX_REPLANS", "DEFAULT_MAX_SAME_START", "DEFAULT_MAX_SUBGOALS",
           "SUCCESS_FEEDBACK", "Alarm", "EpisodeLog", "SubgoalRecord"]
