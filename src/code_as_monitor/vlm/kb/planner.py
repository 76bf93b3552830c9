"""Next subgoal = f(instruction, objects, previous subgoal, feedback): the kb's stateless planning rule.

The instruction is parsed once by the shared grammar; the registered task families are asked in order
(:data:`code_as_monitor.vlm.kb.registry.FAMILY_MODULES`) and the first that understands it plans. Returns the
generator's JSON answer as a dict; :mod:`code_as_monitor.vlm.kb` serialises it.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import VLMError
from code_as_monitor.vlm.grammar import parse
from code_as_monitor.vlm.kb.registry import families


def known_families() -> str:
    """One line per family for messages: ``task: summary (e.g. "example")``."""
    return "; ".join(f"{f.task}: {f.summary} (e.g. {f.example!r})" for f in families())


def next_subgoal(request: dict[str, Any]) -> dict[str, Any]:
    """The generator answer for a request ``{instruction, objects, previous_subgoal, feedback}``.

    Raises:
        VLMError: the kb has no rule for the instruction (it is a rule-based stand-in, not a VLM).
    """
    instruction = str(request.get("instruction", ""))
    objects = [str(o) for o in request.get("objects", [])]
    previous = request.get("previous_subgoal")
    feedback = request.get("feedback")
    ins = parse(instruction)
    for fam in families():
        goal = fam.understand(ins, objects)
        if goal is not None:
            return fam.next_subgoal(goal, previous, feedback)
    shown = ", ".join(objects[:6]) + (", ..." if len(objects) > 6 else "")
    raise VLMError(
        f"kb: no rule for instruction {instruction!r} with objects [{shown}]; the kb is a rule-based stand-in for "
        f"a VLM that knows these task families: {known_families()} (use --backend openai for anything else)"
    )


def infer_objects(instruction: str) -> list[str]:
    """The simulator's object list for an instruction (used when the caller gives none)."""
    ins = parse(instruction)
    for fam in families():
        got = fam.scene(ins)
        if got is not None:
            return got
    return ["table"]
