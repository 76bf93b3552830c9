"""The policy protocol: any open-loop controller the agent can drive tick by tick.

The agent never looks inside a policy. It hands it an :class:`~code_as_monitor.core.Action`, then
interleaves ``step()`` with monitoring, and can stop the motion at once with ``halt()``. A real robot
driver implements the same four members.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from code_as_monitor.core.constraints import Action


@runtime_checkable
class Policy(Protocol):
    """A controller that executes one subgoal-level action at a time."""

    def start(self, action: Action) -> None:
        """Begin executing ``action`` (raises a CamError subclass naming an unknown skill or object)."""

    def step(self) -> None:
        """Advance one control tick (the world advances with it)."""

    def halt(self) -> None:
        """Stop the current motion immediately (the arm holds its pose; suction state is kept)."""

    @property
    def done(self) -> bool:
        """True when the current action has finished (or was halted)."""
        ...
