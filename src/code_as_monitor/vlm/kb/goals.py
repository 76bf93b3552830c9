"""The goal parameters of a simulator task that an instruction asks for, read by the kb's grammar and families.

``cam run TASK --instruction "..."`` and benchmark conditions set a task's ``instruction``; the task's config
asks :func:`task_goal` for the parameters its success check and ground-truth log follow (the tower order of
stack-in-order, the accepted count band of sweep-half, ...). This reading is rule-based (the kb's grammar, the
same one its planner uses) whatever planner then runs: the task must know its goal to judge the episode.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import InstructionError
from code_as_monitor.vlm.grammar import parse
from code_as_monitor.vlm.kb.planner import infer_objects, understand
from code_as_monitor.vlm.kb.registry import families


def task_goal(task: str, instruction: str, objects: list[str] | None = None) -> dict[str, Any]:
    """The config fields of simulator task ``task`` that ``instruction`` asks for, grounded on ``objects`` (the
    task's scene; inferred from the instruction when None).

    Raises:
        InstructionError: no kb family reads instructions for ``task``; the instruction cannot be read (the
            message says why); or it is an instruction for another task.
    """
    fams = [f for f in families() if f.task == task]
    if not fams:
        tasks = ", ".join(f.task for f in families())
        raise InstructionError(f"no instruction grammar for task {task!r} (the kb reads instructions for {tasks})")
    ins = parse(instruction)
    try:
        fam, goal = understand(ins, objects if objects is not None else infer_objects(instruction))
    except InstructionError:
        other = _task_of(instruction)
        if other is not None and other != task:
            raise InstructionError(f"{instruction!r} is a {other} instruction, not one for {task}") from None
        raise
    if fam.task != task:
        raise InstructionError(f"{instruction!r} is a {fam.task} instruction, not one for {task}")
    return fam.task_params(goal)


def _task_of(instruction: str) -> str | None:
    """The task an instruction is for, read on its own scene; None when it cannot be read."""
    try:
        return understand(parse(instruction), infer_objects(instruction))[0].task
    except InstructionError:
        return None
