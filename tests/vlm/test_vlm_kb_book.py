"""kb rules for stow-book: the open-loop plan and recovery subgoals from failure feedback."""

from __future__ import annotations

import pytest

from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.tasks import infer_objects

BOOK = "put the book upright into the bookshelf"


def _chain(feedbacks: list[str | None]):
    gen, prev, out = ConstraintGenerator(KBBackend()), None, []
    for fb in feedbacks:
        prev = gen.next_subgoal(BOOK, {}, infer_objects(BOOK), prev, fb)
        out.append(prev)
    return out


def test_book_plan_matches_the_task_default_plan_and_uses_the_spine_line():
    from code_as_monitor.sim.env import make_task

    plan = make_task("stow-book").default_plan()
    subgoals = _chain([None, "success", "success", "success"])
    assert [(s.action.skill, s.action.args) for s in subgoals[:3]] == [(a.skill, a.args) for a in plan]
    assert subgoals[3].done
    kinds = {(p.part, p.kind.value) for s in subgoals[:3] for c in s.constraints for p in c.parts}
    assert ("spine", "line") in kinds and ("slot", "surface") in kinds


@pytest.mark.parametrize(("after", "feedback", "skill"), [
    (0, "failure: aligned_book: book spine turned 40.0 degrees while the gripper approached", "grasp"),
    (2, "failure: poised_book: book is tilted in the gripper", "reorient"),
    (2, "failure: conveyed_book: book dropped", "grasp"),
    (2, "failure: standing_book: book is not standing", "grasp"),
    (2, "failure: aimed_bookshelf: book is low beside the slot", "reorient"),
    (2, "failure: freed_book: book is still held", "stow"),
])
def test_book_recovery_subgoals(after, feedback, skill):
    prev = _chain([None, "success", "success"][: after + 1])[-1]
    nxt = ConstraintGenerator(KBBackend()).next_subgoal(BOOK, {}, infer_objects(BOOK), prev, feedback)
    assert nxt.action.skill == skill
