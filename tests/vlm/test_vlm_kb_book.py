"""kb rules for stow-book: the open-loop plan, recovery subgoals from failure feedback, programs that pass the
monitor's gates (validation and path coverage in a real sandbox) and checks that decide right."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects

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


validate = pytest.importorskip("code_as_monitor.monitor.validate")
coverage = pytest.importorskip("code_as_monitor.monitor.coverage")
sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")

SLOT = [[0.425, -0.225, 0.087], [0.575, -0.225, 0.087], [0.575, -0.075, 0.087], [0.425, -0.075, 0.087]]
# Plausible states at the start of each stow-book subgoal (world metres).
BOOK_STARTS = [
    {("robot", "tip"): [0.32, -0.33, 0.34], ("book", "cover"): [0.47, 0.12, 0.024],
     ("book", "spine"): [[0.37, 0.185, 0.024], [0.57, 0.185, 0.024]]},
    {("robot", "tip"): [0.47, 0.12, 0.22], ("book", "cover"): [0.47, 0.12, 0.23],
     ("book", "spine"): [[0.37, 0.185, 0.22], [0.57, 0.185, 0.22]]},
    {("robot", "tip"): [0.47, 0.12, 0.22], ("book", "cover"): [0.47, 0.12, 0.22],
     ("book", "spine"): [[0.47, 0.185, 0.12], [0.47, 0.185, 0.32]], ("bookshelf", "slot"): SLOT},
]


def test_book_programs_pass_validation_and_path_coverage(make_elements):
    from code_as_monitor.planning import MonitorCoder

    coder = MonitorCoder(KBBackend())
    box = sandbox.Sandbox()
    box.start()
    try:
        for subgoal, start in zip(_chain([None, "success", "success"]), BOOK_STARTS):
            els = make_elements(subgoal, start)
            cons = subgoal.constraints
            src = coder.write_program(subgoal, els, {}, lambda s, cons=cons: validate.validate_program(s, cons))
            coverage.check_path_coverage(src, cons, {e.id: e.points for e in els}, None, None, 0.0, box,
                                     reject_failing_at_start=True)
    finally:
        box.close()


def test_book_checks_decide_right_on_constructed_states(make_elements, run_program):
    from code_as_monitor.planning import MonitorCoder

    grasp, _, stow = _chain([None, "success", "success"])
    src = MonitorCoder(KBBackend()).write_program(grasp, make_elements(grasp, BOOK_STARTS[0]), {}, lambda s: None)
    els = make_elements(grasp, BOOK_STARTS[0])
    turned = make_elements(grasp, {**BOOK_STARTS[0], ("book", "spine"): [[0.42, 0.06, 0.024], [0.52, 0.23, 0.024]]})
    hist = [np.stack([a.points, b.points]) for a, b in zip(els, turned)]
    assert run_program(src, els)["aligned_book"][0]
    assert not run_program(src, turned, hist)["aligned_book"][0]
    src = MonitorCoder(KBBackend()).write_program(stow, make_elements(stow, BOOK_STARTS[2]), {}, lambda s: None)
    tilted = {**BOOK_STARTS[2], ("book", "spine"): [[0.40, 0.185, 0.14], [0.54, 0.185, 0.30]]}
    assert not run_program(src, make_elements(stow, tilted))["poised_book"][0]
    stood = {("robot", "tip"): [0.5, -0.15, 0.3], ("book", "cover"): [0.5, -0.15, 0.106],
             ("book", "spine"): [[0.5, -0.085, 0.006], [0.5, -0.085, 0.206]], ("bookshelf", "slot"): SLOT}
    r = run_program(src, make_elements(stow, stood))
    assert r["shelved_bookshelf"][0] and r["freed_book"][0] and r["standing_book"][0] and r["conveyed_book"][0]
    flat = {**stood, ("book", "cover"): [0.5, 0.06, 0.024],
            ("book", "spine"): [[0.4, 0.125, 0.024], [0.6, 0.125, 0.024]]}
    r = run_program(src, make_elements(stow, flat))
    assert not r["standing_book"][0] and not r["shelved_bookshelf"][0] and not r["conveyed_book"][0]


# The grasp's start after a stow dropped the book standing in the shelf (book-c, episode 0): the painter saw only
# the top of the spine above the shelf, a short line 20 cm up (world metres, from the record).
IN_SHELF = {("robot", "tip"): [0.434, -0.172, 0.241], ("book", "cover"): [0.438, -0.176, 0.102],
            ("book", "spine"): [[0.375, -0.186, 0.201], [0.368, -0.163, 0.201]]}


def test_book_grasp_program_passes_path_coverage_on_a_book_resting_high(make_elements):
    """A book resting with its whole spine above 15 cm is not 'up in the gripper': the aligned check must
    still be able to fail there (an absolute height made it always True and path coverage rejected it)."""
    from code_as_monitor.planning import MonitorCoder

    grasp = _chain([None])[0]
    els = make_elements(grasp, IN_SHELF)
    box = sandbox.Sandbox()
    box.start()
    try:
        src = MonitorCoder(KBBackend()).write_program(grasp, els, {}, lambda s: None)
        coverage.check_path_coverage(src, grasp.constraints, {e.id: e.points for e in els}, None, None, 0.0, box,
                                     reject_failing_at_start=True)
    finally:
        box.close()


def test_book_aligned_judges_a_resting_book_by_its_turn_and_a_risen_one_as_held(make_elements, run_program,
                                                                                history_of):
    from code_as_monitor.planning import MonitorCoder

    grasp = _chain([None])[0]
    start = make_elements(grasp, IN_SHELF)
    src = MonitorCoder(KBBackend()).write_program(grasp, start, {}, lambda s: None)
    turned = make_elements(grasp, {**IN_SHELF, ("book", "spine"): [[0.36, -0.18, 0.201], [0.383, -0.169, 0.201]]})
    assert not run_program(src, turned, history_of(start, turned))["aligned_book"][0]
    lifted = make_elements(grasp, {**IN_SHELF, ("book", "spine"): [[0.36, -0.18, 0.30], [0.383, -0.169, 0.30]]})
    assert run_program(src, lifted, history_of(start, lifted))["aligned_book"][0]
    flat_turned = make_elements(grasp, {**BOOK_STARTS[0], ("book", "spine"): [[0.42, 0.06, 0.16],
                                                                               [0.52, 0.23, 0.16]]})
    flat = make_elements(grasp, BOOK_STARTS[0])
    assert run_program(src, flat_turned, history_of(flat, flat_turned))["aligned_book"][0], \
        "a book risen 14 cm with the gripper may turn"
