"""kb rules for the gripper tasks: the open-loop plan, recovery subgoals from failure feedback, and programs
that pass the monitor's own gates (static validation and white-box path coverage in a real sandbox)."""

from __future__ import annotations

import pytest

from code_as_monitor.planning import ConstraintGenerator, MonitorCoder
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.shared.feedback import failed_kind

validate = pytest.importorskip("code_as_monitor.monitor.validate")
coverage = pytest.importorskip("code_as_monitor.monitor.coverage")
sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")

PEN = "put the pen into the pen holder"
RIM = [[0.47, -0.13, 0.08], [0.53, -0.13, 0.08], [0.53, -0.07, 0.08], [0.47, -0.07, 0.08]]
# Plausible states at the start of each slot-pen subgoal (world metres).
PEN_STARTS = [
    {("robot", "tip"): [0.32, -0.33, 0.34], ("pen", "body"): [[0.42, 0.08, 0.012], [0.53, 0.1, 0.012]]},
    {("robot", "tip"): [0.47, 0.09, 0.22], ("pen", "body"): [[0.42, 0.08, 0.225], [0.53, 0.1, 0.222]]},
    {("robot", "tip"): [0.47, 0.09, 0.22], ("pen", "body"): [[0.47, 0.09, 0.167], [0.47, 0.09, 0.276]],
     ("pen", "tip"): [0.47, 0.09, 0.135], ("pen_holder", "rim"): RIM},
]


def _gen() -> ConstraintGenerator:
    return ConstraintGenerator(KBBackend())


def _chain(feedbacks: list[str | None]):
    gen, prev, out = _gen(), None, []
    for fb in feedbacks:
        prev = gen.next_subgoal(PEN, {}, infer_objects(PEN), prev, fb)
        out.append(prev)
    return out


def test_pen_plan_matches_the_task_default_plan():
    from code_as_monitor.sim.env import make_task

    plan = make_task("slot-pen").default_plan()
    subgoals = _chain([None, "success", "success", "success"])
    assert [(s.action.skill, s.action.args) for s in subgoals[:3]] == [(a.skill, a.args) for a in plan]
    assert subgoals[3].done


@pytest.mark.parametrize(("after", "feedback", "skill"), [
    (0, "failure: steady_pen: pen moved 0.040 m while the gripper approached", "grasp"),
    (0, "failure: grasped_pen: pen is not held in the gripper", "grasp"),
    (1, "failure: gripped_pen: pen dropped: it is 0.060 m from the grasp point", "grasp"),
    (1, "failure: upright_pen: pen is not upright: 30.0 degrees from vertical", "reorient"),
    (2, "failure: carried_pen: pen dropped: it is 0.100 m from the grasp point and not inside pen_holder", "grasp"),
    (2, "failure: over_pen_holder: pen tip is 0.020 m above the rim but offset 0.080 m", "reorient"),
    (2, "failure: inside_pen_holder: pen is not inside pen_holder", "grasp"),
    (2, "failure: freed_pen: pen is still held", "insert"),
])
def test_pen_recovery_subgoals(after, feedback, skill):
    prev = _chain([None, "success", "success"][: after + 1])[-1]
    nxt = _gen().next_subgoal(PEN, {}, infer_objects(PEN), prev, feedback)
    assert nxt.action.skill == skill


def test_failed_kind_reads_the_constraint_id_then_keywords():
    assert failed_kind("success") == "success"
    assert failed_kind("failure: over_pen_holder: whatever") == "over"
    assert failed_kind("the pen was dropped on the way") == "gripped"


def test_pen_programs_pass_validation_and_path_coverage(make_elements):
    coder = MonitorCoder(KBBackend())
    box = sandbox.Sandbox()
    box.start()
    try:
        for subgoal, start in zip(_chain([None, "success", "success"]), PEN_STARTS):
            kinds = {p.kind.value for c in subgoal.constraints for p in c.parts}
            els = make_elements(subgoal, start)
            cons = subgoal.constraints
            src = coder.write_program(subgoal, els, {}, lambda s, cons=cons: validate.validate_program(s, cons))
            E = {e.id: e.points for e in els}
            coverage.check_path_coverage(src, cons, E, None, None, 0.0, box,
                                     reject_failing_at_start=True)
            assert "line" in kinds
        assert "surface" in kinds  # the insert subgoal uses the opening's surface
        assert coder.usage.calls == 3
    finally:
        box.close()


def test_pen_checks_decide_right_on_constructed_states(make_elements, run_program):
    insert = _chain([None, "success", "success"])[2]
    src = MonitorCoder(KBBackend()).write_program(insert, make_elements(insert, PEN_STARTS[2]), {}, lambda s: None)
    base = dict(PEN_STARTS[2])
    inside = {**base, ("pen", "tip"): [0.5, -0.1, 0.03], ("robot", "tip"): [0.5, -0.1, 0.25],
              ("pen", "body"): [[0.5, -0.1, 0.05], [0.5, -0.1, 0.16]]}
    r = run_program(src, make_elements(insert, inside))
    assert r["inside_pen_holder"][0] and r["freed_pen"][0] and r["carried_pen"][0]
    missed = {**base, ("pen", "tip"): [0.58, -0.1, 0.1]}
    assert not run_program(src, make_elements(insert, missed))["over_pen_holder"][0]
    # The opening's centre is (0.5, -0.1) at rim height 0.08: the tip must be within 1.9 cm while it enters
    # (3 cm above the rim to the rim), within 3 cm below the rim (to 2 cm below: it is in the 5 x 5 cm opening,
    # not beside the holder); deeper in, the upon checks judge it.
    def over(x: float, z: float) -> bool:
        return run_program(src, make_elements(insert, {**base, ("pen", "tip"): [x, -0.1, z]}))["over_pen_holder"][0]
    assert over(0.517, 0.09) and over(0.517, 0.07)  # 1.7 cm off, 1 cm above / below the rim: it enters
    assert not over(0.523, 0.09)  # 2.3 cm off, 1 cm above the rim: it will hit the rim
    assert over(0.523, 0.07) and over(0.51, 0.07)  # 1 cm below the rim, by the wall: it entered
    assert not over(0.538, 0.07)  # 3.8 cm off, 1 cm below the rim: beside the holder, it missed
    assert over(0.523, 0.15)  # still high
    assert over(0.523, 0.05)  # 3 cm below the rim: the upon checks judge it
    tilted = {**base, ("pen", "body"): [[0.42, 0.09, 0.2], [0.53, 0.09, 0.24]]}
    assert not run_program(src, make_elements(insert, tilted))["upright_pen"][0]
