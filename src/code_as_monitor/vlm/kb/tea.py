"""kb rules for ``pour-tea``: understanding, constraint builders and the stateless next-subgoal rule."""

from __future__ import annotations

from typing import Any


def understand(instruction: str, objects: list[str]) -> tuple[str, str] | None:
    """(object, target) names grounded on ``objects`` when the instruction is this task's, else None."""
    return None


def infer_objects(instruction: str) -> list[str] | None:
    """The simulator's object list for this task's instruction, or None."""
    return None


def next_tea(obj: str, target: str, previous: dict[str, Any] | None, kind: str) -> dict[str, Any]:
    """The next subgoal; ``kind`` is the failed constraint's key (or ``success``)."""
    raise NotImplementedError("pour-tea: kb rules not written yet")
