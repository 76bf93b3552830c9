"""Next subgoal = f(instruction, objects, previous subgoal, feedback): the kb's stateless planning rule.

The instruction is parsed once by the shared grammar (:mod:`code_as_monitor.vlm.grammar`); every registered
task family reads it (:data:`code_as_monitor.vlm.kb.registry.FAMILY_MODULES`). Exactly one complete reading
plans. None is a refusal naming what was not understood (and every family the kb knows); two are an ambiguous
instruction (refused, naming both). The kb never plans a reading that leaves part of the instruction unused.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import InstructionError
from code_as_monitor.vlm.grammar import Instruction, parse
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.registry import families
from code_as_monitor.vlm.kb.shared.reading import check_generic


def known_families() -> str:
    """Every family for messages: ``task (summary, e.g. "example")``."""
    return "; ".join(f"{f.task} ({f.summary}, e.g. {f.example!r})" for f in families())


def understand(instruction: str | Instruction, objects: list[str]) -> tuple[TaskFamily, Any]:
    """The one family that reads ``instruction`` completely on ``objects``, and its goal.

    Raises:
        InstructionError: no family reads it (the message says why, per family that recognised it, and lists
            every family), or two do (ambiguous).
    """
    ins = instruction if isinstance(instruction, Instruction) else parse(instruction)
    check_generic(ins, known_families())
    goals: list[tuple[TaskFamily, Any]] = []
    errors: list[tuple[int, str]] = []
    for fam in families():
        try:
            goal = fam.understand(ins, objects)
        except InstructionError as exc:
            errors.append((getattr(exc, "relevance", 0), str(exc)))
            continue
        if goal is not None:
            goals.append((fam, goal))
    if len(goals) == 1:
        return goals[0]
    if goals:
        tasks = " and as ".join(f.task for f, _ in goals)
        raise InstructionError(f"kb: {ins.text!r} is ambiguous: it reads as {tasks}")
    shown = ", ".join(objects[:6]) + (", ..." if len(objects) > 6 else "")
    best = max((rel for rel, _ in errors), default=0)
    why = "; ".join(msg for rel, msg in errors if rel == best) if errors else (
        f"kb: no task family recognises {ins.text!r} with objects [{shown}]")
    raise InstructionError(f"{why}. The kb is a rule-based stand-in for a VLM; it knows these task families: "
                           f"{known_families()} (use --backend openai for anything else)")


def next_subgoal(request: dict[str, Any]) -> dict[str, Any]:
    """The generator answer for a request ``{instruction, objects, previous_subgoal, feedback}``.

    Raises:
        InstructionError: the kb cannot read the instruction (see :func:`understand`).
    """
    objects = [str(o) for o in request.get("objects", [])]
    fam, goal = understand(str(request.get("instruction", "")), objects)
    return fam.next_subgoal(goal, request.get("previous_subgoal"), request.get("feedback"))


def infer_objects(instruction: str) -> list[str]:
    """The simulator's object list for an instruction (used when the caller gives none): the scene of the family
    that reads it on its own scene, else of the first family that recognises it, else just the table."""
    ins = parse(instruction)
    first: list[str] | None = None
    for fam in families():
        objs = fam.scene(ins)
        if objs is None:
            continue
        first = first or objs
        try:
            if fam.understand(ins, objs) is not None:
                return objs
        except InstructionError:
            continue
    return first or ["table"]
