"""Next subgoal = f(instruction, objects, previous subgoal, feedback): the kb's stateless task rules.

Returns the generator's JSON answer as a dict; :mod:`code_as_monitor.vlm.kb` serialises it. Recovery
rules follow :mod:`code_as_monitor.vlm.kb.feedback`.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import VLMError
from code_as_monitor.vlm.kb import manip, skills
from code_as_monitor.vlm.kb.feedback import classify, mentioned
from code_as_monitor.vlm.kb.tasks import TaskSpec, understand
from code_as_monitor.vlm.kb.thresholds import DEFAULT_ROPE_BEADS


def _done(why: str) -> dict[str, Any]:
    return {"subgoal": "task complete", "done": True, "action": None, "constraints": [], "reasoning": why}


def _pick(task: TaskSpec, level: int, why: str) -> dict[str, Any]:
    obj = task.tower[level]
    return skills.answer(f"pick up {skills.nice(obj)}", "pick", {"obj": obj}, skills.pick(obj), why)


def _place(task: TaskSpec, level: int, why: str) -> dict[str, Any]:
    obj, target = task.tower[level], task.tower[level - 1]
    below = [(task.tower[i], task.tower[i - 1]) for i in range(1, level)]
    cons = skills.place_on(obj, target, below)
    return skills.answer(
        f"place {skills.nice(obj)} on {skills.nice(target)}",
        "place_on", {"obj": obj, "target": target}, cons, why,
    )


def _stack(task: TaskSpec, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    tower = task.tower
    action = (previous or {}).get("action") or {}
    skill, args = action.get("skill"), action.get("args") or {}
    obj = args.get("obj")
    if not previous or skill not in ("pick", "place_on") or obj not in tower[1:]:
        if previous and previous.get("done"):
            return _done("the tower is complete")
        return _pick(task, 1, f"{tower[0]} is the base and stays on the table; the next level is {tower[1]}")
    level = tower.index(obj)
    cat = classify(feedback)
    if cat == "collapse":
        levels = [tower.index(n) for n in mentioned(feedback, tower)]
        lowest = max(1, min(levels)) if levels else 1
        return _pick(task, lowest, f"the tower was disturbed; restart from the lowest level that may be missing, "
                                   f"{tower[lowest]} (level {lowest})")
    if skill == "pick":
        if cat == "success":
            return _place(task, level, f"{obj} is held; put it on {tower[level - 1]}")
        return _pick(task, level, f"{obj} is not held ({cat}); pick it again")
    # place_on
    if cat == "success":
        if level == len(tower) - 1:
            return _done("every block is stacked in order")
        return _pick(task, level + 1, f"{obj} is placed; the next level is {tower[level + 1]}")
    if cat == "offset":
        return _pick(task, level, f"{obj} is off-centre, so the next block would topple the tower; pick it "
                                  f"again and re-place it")
    if cat == "dropped":
        return _pick(task, level, f"{obj} was dropped before it rested on {tower[level - 1]}; pick it again")
    return _place(task, level, f"the placement of {obj} did not finish ({cat}); place it again")


def _sweep(task: TaskSpec, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    cons, why = skills.push_into_region(task.blocks, task.region)
    if previous and previous.get("action"):
        cat = classify(feedback)
        if cat == "success":
            return _done("about half of the blocks are inside the zone")
        if cat == "overshoot":
            return _done("more blocks than the accepted band are inside the zone and no skill can take them "
                         "out; stopping")
        why = f"the previous push did not reach the target ({cat}); keep pushing. " + why
    text = f"push blocks into {skills.nice(task.region)} until about half of them are inside"
    return skills.answer(text, "push_into_region", {"region": task.region}, cons, why)


def _rope(task: TaskSpec, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    why = "the opening lies between corner_3 and corner_0; it is enclosed when rope beads lie all along it"
    if previous and previous.get("action"):
        cat = classify(feedback)
        if cat == "success":
            return _done("the opening of the square is enclosed by the rope")
        why = f"the opening is not enclosed yet ({cat}); keep adjusting the rope. " + why
    cons = skills.close_shape(task.rope, task.shape, task.rope_beads)
    text = f"close the opening of {skills.nice(task.shape)} with {skills.nice(task.rope)}"
    return skills.answer(text, "close_shape", {"rope": task.rope, "shape": task.shape}, cons, why)


def next_subgoal(request: dict[str, Any]) -> dict[str, Any]:
    """The generator answer for a request ``{instruction, objects, previous_subgoal, feedback}``.

    Raises:
        VLMError: the kb has no rule for the instruction (it is a rule-based stand-in, not a VLM).
    """
    instruction = str(request.get("instruction", ""))
    objects = [str(o) for o in request.get("objects", [])]
    previous = request.get("previous_subgoal")
    feedback = request.get("feedback")
    task = understand(instruction, objects, DEFAULT_ROPE_BEADS)
    manip_task = manip.understand(instruction, objects) if task is None else None
    if manip_task is not None:
        return manip.next_subgoal(manip_task, previous, feedback)
    if task is None:
        shown = ", ".join(objects[:6]) + (", ..." if len(objects) > 6 else "")
        raise VLMError(
            f"kb: no rule for instruction {instruction!r} with objects [{shown}]; "
            "the kb is a rule-based stand-in for a VLM covering stack, sweep-half, rope-close and slot-pen tasks "
            "(use --backend openai for anything else)"
        )
    if task.family == "stack":
        return _stack(task, previous, feedback)
    if task.family == "sweep":
        return _sweep(task, previous, feedback)
    return _rope(task, previous, feedback)
