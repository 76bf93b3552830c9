"""What a task family of the kb is: one module's understanding, constraints, thresholds, templates and recovery.

A family module (``vlm/kb/families/<name>.py``) ends with ``FAMILY = TaskFamily(...)``, and one line in
:data:`code_as_monitor.vlm.kb.registry.FAMILY_MODULES` registers it. The shared grammar
(:mod:`code_as_monitor.vlm.grammar`) parses the instruction once; each family grounds the parse on the scene's
objects (``understand``) and plans from what it understood (``next_subgoal``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.shared.codegen import Template

Answer = dict[str, Any]
"""The generator's JSON answer for one subgoal (see :mod:`code_as_monitor.vlm.schemas`)."""


@dataclass(frozen=True)
class TaskFamily:
    """One task family of the kb.

    Attributes:
        name: short family name ("stack", "pen", ...), unique.
        task: the simulator task it plans for (``cam run TASK``), e.g. "stack-in-order".
        summary: what it does, for the kb's refusal message ("stack coloured blocks in a given order").
        example: an instruction it understands.
        understand: ``(instruction, objects) -> goal or None``: the family's goal grounded on the scene's object
            names (``"obj/part"`` entries list parts); None when the instruction is not about this family. It
            raises :class:`~code_as_monitor.core.errors.InstructionError` naming what it cannot honour when
            the instruction is about this family but asks for something it cannot plan.
        next_subgoal: ``(goal, previous answer or None, feedback or None) -> answer``: the stateless rule.
        scene: ``instruction -> object names or None``: the simulator's object list for an instruction of this
            family (used when the caller gives no objects).
        task_params: ``goal -> dict``: the simulator task's config fields that make its success check and
            ground-truth log follow the goal (``{}`` when the task has none).
        thresholds: constraint kind -> its thresholds (merged into the kb's table; names must be unique).
        templates: template key (constraint id prefix) -> writer of the check (keys must be unique).
        keywords: fallbacks for constraint ids without a known prefix: (word in the text, template key).
    """

    name: str
    task: str
    summary: str
    example: str
    understand: Callable[[Instruction, list[str]], Any]
    next_subgoal: Callable[[Any, dict[str, Any] | None, str | None], Answer]
    scene: Callable[[Instruction], list[str] | None]
    task_params: Callable[[Any], dict[str, Any]] = lambda goal: {}
    thresholds: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    templates: Mapping[str, Template] = field(default_factory=dict)
    keywords: tuple[tuple[str, str], ...] = ()
