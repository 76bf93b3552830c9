"""kb rules for pour-tea: the open-loop plan, recovery subgoals from failure feedback, programs that pass the
monitor's gates (validation and path coverage in a real sandbox) and checks that decide right."""

from __future__ import annotations

import math

import numpy as np
import pytest

from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.families.tea import CARRY_ON
from code_as_monitor.vlm.kb.planner import infer_objects

TEA = "pour the tea from the teapot into the teacup"


def _chain(feedbacks: list[str | None]):
    gen, prev, out = ConstraintGenerator(KBBackend()), None, []
    for fb in feedbacks:
        prev = gen.next_subgoal(TEA, {}, infer_objects(TEA), prev, fb)
        out.append(prev)
    return out


def _next(prev, feedback: str):
    return ConstraintGenerator(KBBackend()).next_subgoal(TEA, {}, infer_objects(TEA), prev, feedback)


def test_tea_plan_matches_the_task_default_plan_and_uses_surfaces():
    from code_as_monitor.sim.env import make_task

    plan = make_task("pour-tea").default_plan()
    subgoals = _chain([None, "success", "success", "success", "success", "success"])
    assert [(s.action.skill, s.action.args) for s in subgoals[:5]] == [(a.skill, a.args) for a in plan]
    assert subgoals[5].done
    kinds = {(p.part, p.kind.value) for s in subgoals[:5] for c in s.constraints for p in c.parts}
    assert {("lid", "surface"), ("rim", "surface"), ("spout", "point"), ("handle", "point")} <= kinds
    level = next(c for c in subgoals[1].constraints if c.id == "potlevel_teapot")
    assert level.phase.value == "during" and level.thresholds["max_tilt"] == pytest.approx(math.radians(15.0))


@pytest.mark.parametrize(("after", "feedback", "skill"), [
    (1, "failure: potlevel_teapot: teapot is not level: its lid is tilted 24.0 degrees", "level"),
    (1, "failure: gripped_teapot: teapot dropped", "grasp"),
    (1, "failure: spoutover_teacup: the spout is not above the cup", "transport"),
    (2, "failure: pourtilt_teapot: teapot is tipped only 42.0 degrees spout-down", "pour"),
    (2, "failure: spoutover_teacup: the spout is not above the cup", "level"),
    (3, "failure: draintilt_teapot: teapot went back towards level", "pour"),
    (0, "failure: grasped_teapot: teapot is not held", "grasp"),
])
def test_tea_recovery_subgoals(after, feedback, skill):
    prev = _chain([None, "success", "success", "success"][: after + 1])[-1]
    assert _next(prev, feedback).action.skill == skill


def test_tea_recovery_levels_then_carries_on_or_sets_down():
    transport = _chain([None, "success"])[-1]
    again = _next(transport, "failure: potlevel_teapot: teapot is not level")
    assert again.action.skill == "level" and CARRY_ON in again.text
    assert _next(again, "success").action.skill == "transport"  # levelled: carry on
    down = _next(again, "failure: potlevel_teapot: teapot is not level")  # the wrist could not level it
    assert down.action.skill == "set_down"
    assert _next(down, "success").action.skill == "grasp"
    assert _next(down, "failure: freed_teapot: teapot is still held").action.skill == "set_down"
    final = _chain([None, "success", "success", "success", "success"])[-1]
    assert final.action.skill == "level" and CARRY_ON not in final.text
    assert _next(final, "success").done


validate = pytest.importorskip("code_as_monitor.monitor.validate")
coverage = pytest.importorskip("code_as_monitor.monitor.coverage")
sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")


def _square(centre, half: float, tilt_deg: float = 0.0) -> list[list[float]]:
    """Four corners (4, 3) of a square of half-size ``half`` about ``centre``, turned ``tilt_deg`` about y."""
    a = math.radians(tilt_deg)
    R = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    c = np.asarray(centre, float)
    return [(c + R @ np.array([x, y, 0.0])).tolist() for x, y in ((-half, -half), (half, -half), (half, half),
                                                                   (-half, half))]


RIM = _square([0.47, -0.16, 0.07], 0.045)


def _pot(tip, tilt_deg: float) -> dict:
    """Plausible painted elements of a pot held at ``tip`` (the handle there), its spout towards -y, tipped
    ``tilt_deg`` spout-down."""
    a = math.radians(tilt_deg)
    fwd = np.array([0.0, -math.cos(a), -math.sin(a)])  # the pot's +x (to the spout)
    up = np.array([0.0, -math.sin(a), math.cos(a)])
    h = np.asarray(tip, float)
    body = h + 0.08 * fwd - 0.02 * up  # the pot's bottom centre is 8 cm ahead of the handle and 5 cm below it
    lid = body + 0.086 * up
    corners = [(lid + x * fwd + y * np.array([1.0, 0.0, 0.0])).tolist()
               for x, y in ((-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05))]
    return {("robot", "tip"): list(tip), ("teapot", "handle"): h.tolist(), ("teapot", "lid"): corners,
            ("teapot", "spout"): (body + 0.092 * fwd + 0.032 * up).tolist(), ("teacup", "rim"): RIM}


# Plausible states at the start of each pour-tea subgoal (world metres).
TEA_STARTS = [
    {("robot", "tip"): [0.32, -0.33, 0.34], ("teapot", "handle"): [0.45, 0.22, 0.05],
     ("teapot", "lid"): _square([0.45, 0.14, 0.086], 0.055), ("teapot", "spout"): [0.45, 0.05, 0.03],
     ("teacup", "rim"): RIM},
    _pot([0.45, 0.22, 0.22], 3.0),  # transport: lifted, level
    _pot([0.47, -0.02, 0.17], 5.0),  # pour: the spout above the cup
    _pot([0.47, -0.04, 0.20], 60.0),  # drain: tipped
    _pot([0.47, -0.04, 0.20], 60.0),  # level
]


def test_tea_programs_pass_validation_and_path_coverage(make_elements):
    from code_as_monitor.planning import MonitorCoder

    coder = MonitorCoder(KBBackend())
    box = sandbox.Sandbox()
    box.start()
    try:
        subgoals = _chain([None, "success", "success", "success", "success"])
        down = _next(_next(subgoals[1], "failure: potlevel_teapot: x"), "failure: potlevel_teapot: x")
        assert down.action.skill == "set_down"
        for subgoal, start in [*zip(subgoals, TEA_STARTS), (down, _pot([0.47, 0.02, 0.2], 45.0))]:
            els = make_elements(subgoal, start)
            cons = subgoal.constraints
            src = coder.write_program(subgoal, els, {}, lambda s, cons=cons: validate.validate_program(s, cons))
            coverage.check_path_coverage(src, cons, {e.id: e.points for e in els}, None, None, 0.0, box,
                                     reject_failing_at_start=True)
    finally:
        box.close()


def test_tea_checks_decide_right_on_constructed_states(make_elements, run_program):
    from code_as_monitor.planning import MonitorCoder

    _, transport, pour, drain, _ = _chain([None, "success", "success", "success", "success"])
    coder = MonitorCoder(KBBackend())
    src = coder.write_program(transport, make_elements(transport, TEA_STARTS[1]), {}, lambda s: None)
    assert run_program(src, make_elements(transport, _pot([0.45, 0.22, 0.22], 12.0)))["potlevel_teapot"][0]
    assert not run_program(src, make_elements(transport, _pot([0.45, 0.22, 0.22], 20.0)))["potlevel_teapot"][0]
    r = run_program(src, make_elements(transport, _pot([0.47, -0.02, 0.17], 5.0)))
    assert r["spoutover_teacup"][0] and r["gripped_teapot"][0]
    assert not run_program(src, make_elements(transport, _pot([0.45, 0.22, 0.22], 5.0)))["spoutover_teacup"][0]
    src = coder.write_program(pour, make_elements(pour, TEA_STARTS[2]), {}, lambda s: None)
    assert run_program(src, make_elements(pour, _pot([0.47, -0.04, 0.2], 60.0)))["pourtilt_teapot"][0]
    assert not run_program(src, make_elements(pour, _pot([0.47, -0.04, 0.2], 40.0)))["pourtilt_teapot"][0]
    src = coder.write_program(drain, make_elements(drain, TEA_STARTS[3]), {}, lambda s: None)
    assert run_program(src, make_elements(drain, TEA_STARTS[3]))["draintilt_teapot"][0]
    assert not run_program(src, make_elements(drain, _pot([0.47, -0.04, 0.2], 30.0)))["draintilt_teapot"][0]
    beside = {**TEA_STARTS[3], ("teapot", "spout"): [0.6, -0.16, 0.12]}
    assert not run_program(src, make_elements(drain, beside))["spoutover_teacup"][0]
