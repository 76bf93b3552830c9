"""Subgoals, constraints and verdicts: what the planner produces and what the monitor returns."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.core.errors import ConfigError

_ID_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class Phase(str, Enum):
    """When a constraint must hold."""

    DURING = "during"  # must hold at every frame while the subgoal executes
    UPON = "upon"  # must hold when the subgoal completes

    @classmethod
    def parse(cls, value: str | Phase) -> Phase:
        if isinstance(value, Phase):
            return value
        try:
            return cls(str(value).strip().lower())
        except ValueError:
            raise ConfigError(f"unknown phase {value!r}; expected 'during' or 'upon'") from None


def unknown_members(monotone: list[str], parts: list[Any]) -> list[str]:
    """The entries of a ``monotone`` list that name none of ``parts`` (each with ``name`` and ``obj``)."""
    known = {p.name for p in parts} | {p.obj for p in parts}
    return [m for m in monotone if m not in known]


@dataclass
class Constraint:
    """One textual constraint with the parts it involves.

    Attributes:
        id: identifier, a valid Python name; the monitor program defines ``check_<id>``.
        text: the natural-language constraint.
        phase: during | upon.
        parts: the entities/parts it involves, each with its element kind.
        element_ids: the painted element ids of ``parts`` (filled by the painter, same order).
        thresholds: named numeric tolerances the check uses (metres, radians, counts).
        proactive: True when the constraint predicts a failure (e.g. "the block below is offset, so
            stacking on it will topple"), False when it detects one that happened (reactive).
        monotone: parts (by part ``name`` or object ``obj``) that the check reads as an anonymous set which
            more members can only help to hold: a rope's beads covering a gap, blocks of a pile of which "at
            least n" must lie in a zone. When the only stale elements a check reads are such members, the
            agent runs the check on the members it sees: a True verdict stands (the seen members already
            satisfy it), a False one is no verdict (an unseen member might change it). Empty: every stale
            element leaves the check without a verdict.
    """

    id: str
    text: str
    phase: Phase
    parts: list[ElementSpec] = field(default_factory=list)
    element_ids: list[int] = field(default_factory=list)
    thresholds: dict[str, float] = field(default_factory=dict)
    proactive: bool = False
    monotone: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not _ID_RE.match(self.id):
            raise ConfigError(f"constraint id {self.id!r} is not a valid identifier")
        self.phase = Phase.parse(self.phase)
        bad = unknown_members(self.monotone, self.parts)
        if bad:
            known = sorted({p.name for p in self.parts} | {p.obj for p in self.parts})
            raise ConfigError(f"constraint {self.id!r}: monotone entries {bad} name none of its parts "
                              f"(part names or objects: {known})")

    def monotone_ids(self, ids: list[int]) -> list[int]:
        """Of ``ids`` (one element id per part, parts order), those of the parts named in :attr:`monotone`."""
        names = set(self.monotone)
        return [int(i) for p, i in zip(self.parts, ids) if p.name in names or p.obj in names]

    def monotone_element_ids(self) -> set[int]:
        """Element ids of the parts named in :attr:`monotone` (needs ``element_ids`` filled, parts order)."""
        if not self.monotone or len(self.element_ids) != len(self.parts):
            return set()
        return set(self.monotone_ids(self.element_ids))

    @property
    def function_name(self) -> str:
        return f"check_{self.id}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "text": self.text,
            "phase": self.phase.value,
            "parts": [p.to_dict() for p in self.parts],
            "element_ids": list(self.element_ids),
            "thresholds": dict(self.thresholds),
            "proactive": self.proactive,
            **({"monotone": list(self.monotone)} if self.monotone else {}),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Constraint:
        return cls(
            id=d["id"],
            text=d["text"],
            phase=Phase.parse(d["phase"]),
            parts=[ElementSpec.from_dict(p) for p in d.get("parts", [])],
            element_ids=[int(i) for i in d.get("element_ids", [])],
            thresholds={k: float(v) for k, v in d.get("thresholds", {}).items()},
            proactive=bool(d.get("proactive", False)),
            monotone=[str(m) for m in d.get("monotone", [])],
        )


@dataclass
class Action:
    """The skill handed to the policy for one subgoal.

    Attributes:
        skill: skill name ("pick", "place_on", "push_into_region", ...).
        args: JSON-serialisable skill arguments (object names, region names, targets).
    """

    skill: str
    args: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"skill": self.skill, "args": dict(self.args)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Action:
        return cls(d["skill"], dict(d.get("args", {})))


@dataclass
class Subgoal:
    """The next step of the task.

    Attributes:
        text: natural-language subgoal ("pick up the red block").
        constraints: during and upon constraints.
        action: the skill for the policy.
        done: True when the planner says the whole task is complete (then constraints are empty).
    """

    text: str
    constraints: list[Constraint] = field(default_factory=list)
    action: Action | None = None
    done: bool = False

    def during(self) -> list[Constraint]:
        return [c for c in self.constraints if c.phase is Phase.DURING]

    def upon(self) -> list[Constraint]:
        return [c for c in self.constraints if c.phase is Phase.UPON]

    def to_dict(self) -> dict[str, Any]:
        return {
            "text": self.text,
            "constraints": [c.to_dict() for c in self.constraints],
            "action": self.action.to_dict() if self.action else None,
            "done": self.done,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Subgoal:
        return cls(
            text=d["text"],
            constraints=[Constraint.from_dict(c) for c in d.get("constraints", [])],
            action=Action.from_dict(d["action"]) if d.get("action") else None,
            done=bool(d.get("done", False)),
        )


@dataclass
class Verdict:
    """The result of one check at one frame.

    Attributes:
        constraint_id: which constraint.
        phase: during | upon.
        ok: True when the constraint is satisfied.
        reason: the program's explanation (feedback for re-planning when ``ok`` is False).
        margin: > 0 satisfied, < 0 violated, its size says by how much; NaN when the program gave none.
        t: observation time, seconds.
        fault: True when the program itself failed (exception, timeout, wrong type): not a verdict
            on the world, and never treated as a violation of it.
    """

    constraint_id: str
    phase: Phase
    ok: bool
    reason: str
    margin: float = float("nan")
    t: float = 0.0
    fault: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {
            "constraint_id": self.constraint_id,
            "phase": self.phase.value,
            "ok": self.ok,
            "reason": self.reason,
            "margin": None if self.margin != self.margin else self.margin,
            "t": self.t,
            "fault": self.fault,
        }
