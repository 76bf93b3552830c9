"""kb rules for open-drawer: the plan, recovery subgoals from failure feedback, programs that pass the monitor's
gates (validation and path coverage in a real sandbox) for cabinets facing the robot from any side, and checks
that decide right on constructed states (the slip, the travel along the axis from the element history)."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects

DRAWER = "open the drawer by pulling its handle"
CAB = "drawer_cabinet"


def _chain(feedbacks: list[str | None]):
    gen, prev, out = ConstraintGenerator(KBBackend()), None, []
    for fb in feedbacks:
        prev = gen.next_subgoal(DRAWER, {}, infer_objects(DRAWER), prev, fb)
        out.append(prev)
    return out


def test_drawer_plan_matches_the_task_default_plan():
    from code_as_monitor.sim.env import make_task

    plan = make_task("open-drawer").default_plan()
    subgoals = _chain([None, "success", "success"])
    assert [(s.action.skill, s.action.args) for s in subgoals[:2]] == [(a.skill, a.args) for a in plan]
    assert subgoals[2].done
    ids = [c.id.split("_", 1)[0] for s in subgoals[:2] for c in s.constraints]
    assert ids == ["drawerstill", "handlegrip", "jawshut", "handled", "pulled", "drawerfreed"]
    pull = subgoals[1]
    assert {(c.id.split("_", 1)[0], c.phase.value) for c in pull.constraints} == {
        ("handled", "during"), ("pulled", "upon"), ("drawerfreed", "upon")}


@pytest.mark.parametrize(("after", "feedback", "skill"), [
    (1, "failure: handled_drawer_cabinet: the grasp slipped off the handle of drawer_cabinet", "grasp"),
    (1, "failure: pulled_drawer_cabinet: the drawer came out only 0.05 m", "grasp"),
    (0, "failure: jawshut_drawer_cabinet: the jaws are not closed on the handle", "grasp"),
    (0, "failure: drawerstill_drawer_cabinet: the handle moved", "grasp"),
    (1, "failure: drawerfreed_drawer_cabinet: still held", "pull"),
])
def test_drawer_recovery_subgoals(after, feedback, skill):
    prev = _chain([None, "success"][: after + 1])[-1]
    nxt = ConstraintGenerator(KBBackend()).next_subgoal(DRAWER, {}, infer_objects(DRAWER), prev, feedback)
    assert nxt.action.skill == skill
    if skill == "grasp":  # and after the re-grasp, the pull again
        again = ConstraintGenerator(KBBackend()).next_subgoal(DRAWER, {}, infer_objects(DRAWER), nxt, "success")
        assert again.action.skill == "pull"


def test_other_instructions_are_not_drawer_tasks():
    from code_as_monitor.core.errors import InstructionError
    from code_as_monitor.vlm.grammar import parse
    from code_as_monitor.vlm.kb.families import drawer

    assert drawer.understand(parse("put the pen into the pen holder"), ["pen", "pen_holder"]) is None
    with pytest.raises(InstructionError, match="no drawer"):  # nothing to ground it on
        drawer.understand(parse("open the drawer"), ["table"])
    assert drawer.understand(parse(DRAWER), [CAB, "table"]) == drawer.DrawerGoal(CAB, "handle")


validate = pytest.importorskip("code_as_monitor.monitor.validate")
coverage = pytest.importorskip("code_as_monitor.monitor.coverage")
sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")


def _scene(yaw: float, subgoal: str) -> dict:
    """A plausible start state of ``subgoal`` for a cabinet whose front (local +x) points along ``yaw``,
    its handle 0.5 m from the robot base (world metres)."""
    u = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    h = np.array([-0.5 * np.cos(yaw), -0.5 * np.sin(yaw), 0.08])
    if subgoal == "grasp":
        tip, jaw = np.array([0.32, -0.33, 0.30]), 0.04  # parked, open
    elif subgoal == "regrasp":
        tip, jaw = h + 0.03 * u, 0.016  # halted just after a slip was seen: beyond the handle, jaws closed
    else:
        tip, jaw = h + np.array([0.0, 0.0, 0.002]), 0.016  # holding the handle
    side = np.array([-u[1], u[0], 0.0])
    return {("robot", "tip"): tip, ("robot", "finger_left"): tip + jaw * u, ("robot", "finger_right"): tip - jaw * u,
            (CAB, "handle"): h, (CAB, "drawer"): h - 0.04 * u + 0.02 * side + [0, 0, 0.015],
            (CAB, "frame"): h - 0.18 * u + [0, 0, 0.09]}


def test_drawer_programs_pass_validation_and_path_coverage(make_elements):
    from code_as_monitor.planning import MonitorCoder

    coder = MonitorCoder(KBBackend())
    grasp, pull = _chain([None, "success"])
    box = sandbox.Sandbox()
    box.start()
    try:
        for yaw in np.radians([180.0, 150.0, -150.0, 205.0, 90.0, 0.0]):  # facing the base, and far beyond
            for subgoal, state in ((grasp, "grasp"), (grasp, "regrasp"), (pull, "pull")):
                els = make_elements(subgoal, _scene(yaw, state))
                cons = subgoal.constraints
                src = coder.write_program(subgoal, els, {}, lambda s, cons=cons: validate.validate_program(s, cons))
                coverage.check_path_coverage(src, cons, {e.id: e.points for e in els}, None, None, 0.0, box,
                                     reject_failing_at_start=True)
    finally:
        box.close()


def test_drawer_checks_decide_right_on_constructed_states(make_elements, run_program):
    from code_as_monitor.planning import MonitorCoder

    grasp, pull = _chain([None, "success"])
    yaw = np.radians(160.0)
    u = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    coder = MonitorCoder(KBBackend())
    # grasp: the open gripper at the bar is not a grasp yet; the closed jaws there are
    at_bar = {**_scene(yaw, "pull")}
    at_bar[("robot", "finger_left")] = at_bar[("robot", "tip")] + 0.04 * u
    at_bar[("robot", "finger_right")] = at_bar[("robot", "tip")] - 0.04 * u
    src = coder.write_program(grasp, make_elements(grasp, at_bar), {}, lambda s: None)
    r = run_program(src, make_elements(grasp, at_bar))
    assert r["handlegrip_drawer_cabinet"][0] and not r["jawshut_drawer_cabinet"][0]
    r = run_program(src, make_elements(grasp, _scene(yaw, "pull")))
    assert r["handlegrip_drawer_cabinet"][0] and r["jawshut_drawer_cabinet"][0]
    # pull: start, slipped, pulled out and released
    start = _scene(yaw, "pull")
    els0 = make_elements(pull, start)
    src = coder.write_program(pull, els0, {}, lambda s: None)

    def moved(state: dict, drawer_out: float, tip_out: float) -> dict:
        s = dict(state)
        for part in ("handle", "drawer"):
            s[(CAB, part)] = state[(CAB, part)] + drawer_out * u
        for part in ("tip", "finger_left", "finger_right"):
            s[("robot", part)] = state[("robot", part)] + tip_out * u
        return s

    def run(state: dict) -> dict:
        els = make_elements(pull, state)
        hist = [np.stack([a.points, b.points]) for a, b in zip(els0, els)]
        return run_program(src, els, hist)

    r = run(moved(start, 0.08, 0.08))  # mid-pull, handle in the grasp
    assert r["handled_drawer_cabinet"][0] and not r["pulled_drawer_cabinet"][0]
    assert not r["drawerfreed_drawer_cabinet"][0]
    r = run(moved(start, 0.05, 0.10))  # slipped at 5 cm, the gripper pulled on
    assert not r["handled_drawer_cabinet"][0]
    assert "slipped" in r["handled_drawer_cabinet"][1]
    done = moved(start, 0.165, 0.17)
    done[("robot", "tip")] = done[("robot", "tip")] + [0.0, 0.0, 0.10]  # let go and retreated up
    r = run(done)
    assert r["handled_drawer_cabinet"][0] and r["pulled_drawer_cabinet"][0] and r["drawerfreed_drawer_cabinet"][0]
    sideways = dict(start)  # a handle point drifting 16 cm sideways is not a drawer coming out
    side = np.array([-u[1], u[0], 0.0])
    sideways[(CAB, "handle")] = start[(CAB, "handle")] + 0.16 * side
    assert not run(sideways)["pulled_drawer_cabinet"][0]
