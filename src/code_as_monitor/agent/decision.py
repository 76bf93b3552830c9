"""What :meth:`Monitor.step <code_as_monitor.agent.monitor.Monitor.step>` tells the control loop."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from code_as_monitor.agent.records import Alarm, SubgoalRecord
from code_as_monitor.core.constraints import Action, Subgoal


class DecisionKind(str, Enum):
    """What happened at this frame.

    - ``start``: the first subgoal was planned; start ``Decision.action``.
    - ``continue``: keep going (nothing was decided, or the frame was not due).
    - ``halt``: a ``during`` check is violated (``violations``); halt the policy. The re-planned next
      subgoal, if any, is in ``subgoal`` / ``action``.
    - ``subgoal_done``: every ``upon`` check holds; halt the policy if it still moves (``halt``), then
      start the next subgoal's ``action``.
    - ``subgoal_failed``: the subgoal failed without a during violation (the policy finished with an
      upon check false, elements not visible, no valid program, perception failed); start the
      re-planned ``action``.
    - ``task_done``: the planner says the task is complete.
    - ``stopped``: the monitor gave up (re-plans or subgoals exhausted, time limit, planner error).
    """

    START = "start"
    CONTINUE = "continue"
    HALT = "halt"
    SUBGOAL_DONE = "subgoal_done"
    SUBGOAL_FAILED = "subgoal_failed"
    TASK_DONE = "task_done"
    STOPPED = "stopped"


@dataclass
class Decision:
    """The monitor's answer to one observation.

    A control loop needs only three fields: ``halt`` (stop the current motion now), ``action`` (start
    this action now; None: keep the current one) and ``finished`` (the episode is over). The rest says
    why.

    Attributes:
        kind: see :class:`DecisionKind`.
        t: the observation's time, seconds.
        halt: stop the policy before anything else.
        action: the new subgoal's action (skill and arguments) to start; None when no subgoal started.
        subgoal: the subgoal now running (None once the episode is over).
        violations: the alarms this frame raised (constraint id, phase, reason, proactive).
        ended: the subgoal that ended at this frame, with its outcome and reason.
        reason: one line saying why (the violation, the stop reason, ...).
    """

    kind: DecisionKind
    t: float
    halt: bool = False
    action: Action | None = None
    subgoal: Subgoal | None = None
    violations: list[Alarm] = field(default_factory=list)
    ended: SubgoalRecord | None = None
    reason: str = ""

    @property
    def finished(self) -> bool:
        """True when the episode is over (task done or the monitor gave up)."""
        return self.kind in (DecisionKind.TASK_DONE, DecisionKind.STOPPED)

    @property
    def skill(self) -> str:
        """The skill of the action to start now ("" when none)."""
        return self.action.skill if self.action is not None else ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind.value, "t": self.t, "halt": self.halt,
            "action": self.action.to_dict() if self.action is not None else None,
            "subgoal": self.subgoal.text if self.subgoal is not None else None,
            "violations": [a.to_dict() for a in self.violations],
            "ended": self.ended.to_dict() if self.ended is not None else None, "reason": self.reason,
        }


__all__ = ["Decision", "DecisionKind"]
