"""kb rules for the RLBench-style tasks (put-in-drawer, screw-bulb, turn-tap, drag-stick, sweep-to-dustpan): the
instructions they read and refuse, plans equal to the tasks' default plans, recovery, programs through the monitor's
gates (validation and path coverage in a real sandbox), and checks that decide right on constructed states."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import InstructionError
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects, understand

INSTRUCTIONS = {
    "put-in-drawer": "open the drawer and put the block in it",
    "screw-bulb": "screw in the light bulb",
    "turn-tap": "turn the left tap",
    "drag-stick": "use the stick to drag the cube onto the red target",
    "sweep-to-dustpan": "sweep the dirt into the dustpan",
}


def _chain(instruction: str, feedbacks: list[str | None]):
    gen, prev, out = ConstraintGenerator(KBBackend()), None, []
    for fb in feedbacks:
        prev = gen.next_subgoal(instruction, {}, infer_objects(instruction), prev, fb)
        out.append(prev)
    return out


@pytest.mark.parametrize("task", list(INSTRUCTIONS))
def test_plan_matches_the_task_default_plan(task: str) -> None:
    from code_as_monitor.sim.env import make_task

    plan = make_task(task).default_plan()
    subgoals = _chain(INSTRUCTIONS[task], [None] + ["success"] * len(plan))
    assert [(s.action.skill, s.action.args) for s in subgoals[:-1]] == [(a.skill, a.args) for a in plan]
    assert subgoals[-1].done
    assert all(s.constraints for s in subgoals[:-1])


@pytest.mark.parametrize(("text", "task", "goal"), [
    ("open the drawer, then put the cube into it", "put-in-drawer", None),
    ("open the drawer and put the block inside", "put-in-drawer", None),  # the particle names the drawer opened
    ("screw the bulb into the lamp", "screw-bulb", None),
    ("turn the right tap", "turn-tap", "right_handle"),
    ("rotate the left faucet", "turn-tap", "left_handle"),
    ("turn on the tap on the right", "turn-tap", "right_handle"),  # the particle before the object, a side after
    ("drag the cube onto the target with the stick", "drag-stick", None),
    ("move the cube onto the red target using the stick", "drag-stick", None),  # the stick's move is the drag
    ("bring the cube to the target with the stick", "drag-stick", None),
    ("drag the cube onto the red square with the stick", "drag-stick", None),  # the target is a red square
    ("use the stick to pull the blue cube onto the square", "drag-stick", None),
    ("sweep the dust into the dustpan with the broom", "sweep-to-dustpan", None),
    ("sweep the dirt into the pan", "sweep-to-dustpan", None),
    ("install the light bulb in the lamp", "screw-bulb", None),
    ("brush the dirt into the dustpan with the broom", "sweep-to-dustpan", None),  # brushing is sweeping
    ("put the bulb in its socket and screw it in", "screw-bulb", None),  # putting it in is part of the screwing
    ("pick up the bulb and screw it into the lamp", "screw-bulb", None),
])
def test_paraphrases_read_as_their_task(text: str, task: str, goal: str | None) -> None:
    fam, g = understand(text, infer_objects(INSTRUCTIONS[task]))
    assert fam.task == task
    if goal is not None:
        assert g.part == goal


@pytest.mark.parametrize("text", [
    "put the block into the drawer after opening the drawer",
    "after opening the drawer, put the block in it",
    "put the block in the drawer after you open the drawer",
    "put the block into the drawer after having opened the drawer",
    "open the drawer before putting the block in it",
    "before putting the block in the drawer, open the drawer",
])
def test_clauses_joined_by_after_or_before_are_planned_in_the_order_they_happen(text: str) -> None:
    """"X after doing Y" is "do Y, then X" (before: refused, 'after' not understood): the same subgoals and checks as
    the task's own instruction."""
    feedbacks = [None] + ["success"] * 6

    def chain(t: str) -> list:
        return [(s.text, s.action, [(c.id, c.thresholds) for c in s.constraints], s.done) for s in _chain(t, feedbacks)]

    assert chain(text) == chain(INSTRUCTIONS["put-in-drawer"])


@pytest.mark.parametrize(("text", "objects", "why"), [
    ("turn the tap", ["tap", "table"], "which tap"),
    ("screw in the green bulb", ["lamp", "table"], "red"),
    ("sweep half of the dirt into the dustpan", ["broom", "dustpan", "dirt_0", "table"], "all the dirt"),
    ("drag the cube with the stick", ["stick", "cube", "target", "table"], "onto the target"),
    ("drag the cube onto the green square with the stick", ["stick", "cube", "target", "table"], "target is red"),
    ("screw the bulb in by 2 turns", ["lamp", "table"], "number of turns"),
    ("screw the bulb 3 turns", ["lamp", "table"], "number of turns"),
    ("put the bulb in the lamp", ["lamp", "table"], "cannot 'put'"),  # putting alone is not screwing
])
def test_what_the_rules_cannot_honour_is_refused(text: str, objects: list[str], why: str) -> None:
    with pytest.raises(InstructionError, match=why):
        understand(text, objects)


def test_turn_tap_takes_its_side_from_the_instruction() -> None:
    from code_as_monitor.sim.env import make_task

    task = make_task("turn-tap", instruction="turn the right tap")
    assert task.config.side == "right" and task.default_plan()[0].args["part"] == "right_handle"


@pytest.mark.parametrize(("text", "angle"), [
    ("turn the right tap 60 degrees", 60.0), ("turn the left tap by 45 degrees", 45.0),
    ("rotate the left faucet about 30 deg", 30.0), ("turn the right tap 90 degrees", None),
    ("turn the left tap 45°", 45.0), ("turn the right tap a quarter turn", None),
    ("turn the left tap one quarter of a turn", None),
    ("turn left tap 45 degrees", 45.0),  # before: "left" read as the verb "leave", refused
    ("rotate the left tap a quarter", None),  # before: refused, "a quarter" a quantity on the tap
])
def test_a_turn_angle_is_read_into_the_plan_and_the_task(text: str, angle: float | None) -> None:
    """"Turn the right tap 60 degrees" asks for a 60-degree turn: the plan turns 60, its checks accept 45 to 75, and
    the task's success asks the same (before, "degrees" was an unknown word, although the kb's own subgoal text reads
    "turn the left tap 90 degrees open"). A quarter-turn is the default: no task parameter, the default plan."""
    from code_as_monitor.sim.env import make_task

    task = make_task("turn-tap", instruction=text)
    want = 90.0 if angle is None else angle
    assert task.config.angle == want
    turn = _chain(text, [None, "success"])[-1]
    assert turn.action.args["angle"] == want == task.default_plan()[1].args["angle"]
    turned = next(c for c in turn.constraints if c.id.startswith("turned"))
    assert turned.thresholds["min_turn"] == pytest.approx(np.radians(want - 15.0), abs=2e-3)
    assert ("max_turn" in turned.thresholds) is (angle is not None)
    least, most = task.turn_band()
    assert np.degrees(least) == pytest.approx(want - 15.0) and np.degrees(most) == pytest.approx(want + 15.0)


@pytest.mark.parametrize(("text", "why"), [
    ("turn the left tap 120 degrees", "30 to 90 degrees"),
    ("turn the left tap 10 degrees", "30 to 90 degrees"),
    ("turn the left tap at least 45 degrees", "one angle"),
    ("turn the left tap 45 degrees and 60 degrees", "one angle"),
    ("turn the left tap 5 cm", "5 cm"),
    ("open the drawer 45 degrees", "by a length"),
    ("turn the left tap half a turn", "'half a turn'"),  # before: planned as a quarter-turn, "half a" unread
    ("turn the left tap a third of a turn", "30 to 90 degrees"),
    ("turn the right tap half", "30 to 90 degrees"),
    ("rotate the left tap three quarters", "30 to 90 degrees"),  # before: "say which tap"
    ("turn half of the left tap", "one handle"),
    ("turn both left taps", "one handle"),  # before: planned as the left tap once "left" read as a side
    ("turn all the taps", "one handle"),
])
def test_an_angle_the_rules_cannot_honour_is_refused(text: str, why: str) -> None:
    objects = ["drawer_cabinet", "table"] if "drawer" in text else ["tap", "table"]
    with pytest.raises(InstructionError, match=why):
        understand(text, objects)


def test_a_turn_angle_out_of_range_is_a_config_error_naming_it() -> None:
    from code_as_monitor.core.errors import ConfigError
    from code_as_monitor.sim.env import make_task

    for bad in (20.0, 95.0, "ninety"):
        with pytest.raises(ConfigError, match=f"turn-tap.angle.*{bad!r}"):
            make_task("turn-tap", angle=bad)


@pytest.mark.parametrize(("task", "after", "feedback", "skill"), [
    ("put-in-drawer", 1, "failure: pulled_drawer_cabinet: the drawer came out only 0.04 m", "grasp"),
    ("put-in-drawer", 3, "failure: overtray_block: not over the open drawer", "grasp"),
    ("put-in-drawer", 3, "failure: freed_block: still held", "put_in"),
    ("screw-bulb", 0, "failure: bulbjaw_lamp: the jaws are not closed on the bulb", "grasp"),
    ("screw-bulb", 1, "failure: freed_lamp: still held", "screw"),
    ("turn-tap", 0, "failure: levergrip_tap: the named lever is not between the fingers", "grasp"),
    ("turn-tap", 1, "failure: leverfreed_tap: still held", "turn"),
    ("drag-stick", 1, "failure: ontarget_cube: the cube is not on the target", "grasp"),
    ("sweep-to-dustpan", 1, "failure: inpan_dustpan: only 2 of 5 dirt pieces", "sweep"),
])
def test_recovery_subgoals(task: str, after: int, feedback: str, skill: str) -> None:
    ins = INSTRUCTIONS[task]
    prev = _chain(ins, [None] + ["success"] * after)[-1]
    nxt = ConstraintGenerator(KBBackend()).next_subgoal(ins, {}, infer_objects(ins), prev, feedback)
    assert nxt.action.skill == skill


# --- constructed states (world metres) ------------------------------------------------------------------------
U = np.array([-1.0, 0.0, 0.0])  # the cabinet's and the tap's front points at the robot base
H = np.array([0.5, 0.0, 0.08])  # the drawer's handle, 0.5 m out


def _robot(tip, jaw=0.04, across=(0.0, 1.0, 0.0)):
    tip, a = np.asarray(tip, float), np.asarray(across, float)
    return {("robot", "tip"): tip, ("robot", "finger_left"): tip + jaw / 2 * a,
            ("robot", "finger_right"): tip - jaw / 2 * a}


def _drawer(opening=0.17):
    # the drawer's element is the centroid of the drawer link's pixels: the tray's middle, behind the handle
    return {("drawer_cabinet", "handle"): H, ("drawer_cabinet", "drawer"): H - 0.12 * U + [0, 0.01, -0.03],
            ("drawer_cabinet", "frame"): H - (0.18 + opening) * U + [0, 0, 0.02]}


def _tap(turn=0.0):
    c, s = np.cos(turn), np.sin(turn)
    lever = np.array([c * U[0] - s * U[1], s * U[0] + c * U[1], 0.0])
    hinge = np.array([0.5, -0.08, 0.063])
    return {("tap", "left_handle"): np.stack([hinge, hinge + 0.077 * lever]),
            ("tap", "right_handle"): np.array([0.47, 0.08, 0.063])}


def _drag(stick_x=0.66, cube=(0.6, 0.0, 0.02), low=True):
    z = 0.014 if low else 0.2
    sq = np.array([[0.37, -0.05, 0.0], [0.47, -0.05, 0.0], [0.47, 0.05, 0.0], [0.37, 0.05, 0.0]])
    return {("stick", "shaft"): np.array([[stick_x, -0.12, z], [stick_x, 0.12, z]]),
            ("stick", "grip"): np.array([stick_x, 0.2, z]), ("cube", ""): np.asarray(cube, float),
            ("target", "surface"): sq}


def _pan(n_in=5):
    floor = np.array([[0.44, 0.12, 0.002], [0.58, 0.12, 0.002], [0.58, 0.30, 0.002], [0.44, 0.30, 0.002]])
    pts = {("dustpan", "pan"): floor, ("broom", "handle"): np.array([0.5, 0.0, 0.1])}
    for i in range(5):
        pts[(f"dirt_{i}", "")] = np.array([0.5 + 0.01 * i, 0.2 if i < n_in else 0.02, 0.01])
    return pts


SCENES = {
    "put-in-drawer": {**_robot([0.32, -0.33, 0.30]), **_drawer(), ("block", ""): np.array([0.45, 0.3, 0.02])},
    "screw-bulb": {**_robot([0.5, 0.0, 0.13], 0.05), ("lamp", "bulb"): np.array([0.5, 0.0, 0.12]),
                   ("lamp", "socket"): np.array([0.5, 0.0, 0.08])},
    "turn-tap": {**_robot([0.46, -0.08, 0.063], 0.034), **_tap()},
    "drag-stick": {**_robot([0.66, 0.2, 0.2]), **_drag(low=False)},
    "sweep-to-dustpan": {**_robot([0.5, 0.0, 0.1]), **_pan(0)},
}

_HELD = np.array([0.45, 0.3, 0.20])  # the block carried at the grasp point
_PARK = np.array([0.32, -0.33, 0.30])  # the tip parked, out of the cameras' way
STARTS = {  # plausible start states of the subgoals that begin with something in hand (default: SCENES)
    ("put-in-drawer", "pull"): {**SCENES["put-in-drawer"], **_drawer(0.0),
                                **_robot(H + np.array([0.0, 0.0, 0.002]), 0.032, across=U)},
    ("put-in-drawer", "put_in"): {**SCENES["put-in-drawer"], **_robot(_HELD), ("block", ""): _HELD},
    ("drag-stick", "grasp"): {**SCENES["drag-stick"], **_robot(_PARK), **_drag()},  # parked, the stick lying
    ("sweep-to-dustpan", "grasp"): {**SCENES["sweep-to-dustpan"], **_robot(_PARK)},
}

validate = pytest.importorskip("code_as_monitor.monitor.validate")
coverage = pytest.importorskip("code_as_monitor.monitor.coverage")
sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")


def test_programs_pass_validation_and_path_coverage(make_elements) -> None:
    coder = MonitorCoder(KBBackend())
    box = sandbox.Sandbox()
    box.start()
    try:
        for task, ins in INSTRUCTIONS.items():
            for subgoal in _chain(ins, [None, "success", "success", "success"]):
                if subgoal.done:
                    break
                els = make_elements(subgoal, STARTS.get((task, subgoal.action.skill), SCENES[task]))
                cons = subgoal.constraints
                src = coder.write_program(subgoal, els, {}, lambda s, cons=cons: validate.validate_program(s, cons))
                coverage.check_path_coverage(src, cons, {e.id: e.points for e in els}, None, None, 0.0, box,
                                             deadline_s=2.0,  # generous: a loaded machine overran 100 ms
                                             reject_failing_at_start=True)
    finally:
        box.close()


def _program(task: str, index: int, make_elements, state: dict):
    sg = _chain(INSTRUCTIONS[task], [None] + ["success"] * index)[-1]
    src = MonitorCoder(KBBackend()).write_program(sg, make_elements(sg, state), {}, lambda s: None)
    return sg, src


def test_put_in_drawer_checks(make_elements, run_program, history_of) -> None:
    tray = {**_robot([0.32, -0.33, 0.30]), **_drawer()}
    _, src = _program("put-in-drawer", 3, make_elements, {**tray, ("block", ""): H - 0.13 * U + [0, 0.02, -0.04]})
    sg = _chain(INSTRUCTIONS["put-in-drawer"], [None, "success", "success", "success"])[-1]
    inside = run_program(src, make_elements(sg, {**tray, ("block", ""): H - 0.13 * U + [0, 0.02, -0.04]}))
    assert inside["intray_block"][0] and inside["overtray_block"][0] and inside["freed_block"][0]
    for where in (H + 0.06 * U + [0, 0, -0.06], H - 0.35 * U + [0, 0, 0.04], H - 0.13 * U + [0, 0.15, -0.04],
                  H - 0.23 * U + [0, 0, 0.04]):  # ... and on the cabinet's top just behind its front face
        out = run_program(src, make_elements(sg, {**tray, ("block", ""): where}))
        assert not out["intray_block"][0], where  # on the table in front, on the cabinet's top, beside the drawer
    # proactive: lowered over the cabinet's top (beyond the open part) is predicted to land outside
    for z, ok in ((0.03, False), (0.045, True), (0.12, True)):  # about to touch the top; carried low; high
        state = make_elements(sg, {**tray, ("block", ""): H - 0.30 * U + np.array([0.0, 0.0, z])})
        assert run_program(src, state)["overtray_block"][0] is ok, z
    # lowered with its centre just ahead of the cabinet's front face: it tips in
    edge = make_elements(sg, {**tray, ("block", ""): H - 0.21 * U + np.array([0.0, 0.0, 0.03])})
    assert run_program(src, edge)["overtray_block"][0]


def test_screw_bulb_checks(make_elements, run_program, history_of) -> None:
    base = SCENES["screw-bulb"]
    grasp, src_g = _program("screw-bulb", 0, make_elements, base)
    missed = {**base, **_robot([0.5, 0.0, 0.13], 0.0)}
    assert not run_program(src_g, make_elements(grasp, missed))["bulbjaw_lamp"][0]
    assert run_program(src_g, make_elements(grasp, base))["bulbjaw_lamp"][0]
    screw, src = _program("screw-bulb", 1, make_elements, base)
    start = make_elements(screw, {**base, **_robot([0.5, 0.0, 0.25])})
    for above, ok in ((0.031, True), (0.037, True), (0.042, False), (0.046, False)):  # seated .. 1.5 cm out
        now = make_elements(screw, {**base, **_robot([0.5, 0.0, 0.25]),
                                    ("lamp", "bulb"): base[("lamp", "socket")] + np.array([0.0, 0.0, above])})
        assert run_program(src, now, history_of(start, now))["screwed_lamp"][0] is ok


def test_turn_tap_checks(make_elements, run_program, history_of) -> None:
    base = SCENES["turn-tap"]
    grasp, src_g = _program("turn-tap", 0, make_elements, base)
    assert run_program(src_g, make_elements(grasp, base))["levergrip_tap"][0]
    wrong = {**base, **_robot([0.46, 0.08, 0.063], 0.034)}  # holding the right handle instead
    assert not run_program(src_g, make_elements(grasp, wrong))["levergrip_tap"][0]
    turn, src = _program("turn-tap", 1, make_elements, base)
    start = make_elements(turn, base)
    for angle, ok in ((np.radians(-88.0), True), (np.radians(-40.0), False)):
        now = make_elements(turn, {**base, **_tap(angle)})
        assert run_program(src, now, history_of(start, now))["turned_tap"][0] is ok


def test_a_smaller_turn_is_judged_in_its_band(make_elements, run_program, history_of) -> None:
    """A 60-degree turn asked for is judged turned at 45 to 75 degrees: short of it and past it are failures, and
    its program passes validation and path coverage (the probes turn lines about the vertical through every band)."""
    text, base = "turn the left tap 60 degrees", SCENES["turn-tap"]
    turn = _chain(text, [None, "success"])[-1]
    els = make_elements(turn, base)
    src = MonitorCoder(KBBackend()).write_program(turn, els, {},
                                                  lambda s: validate.validate_program(s, turn.constraints))
    start = make_elements(turn, base)
    for deg, ok in ((-40.0, False), (-50.0, True), (-60.0, True), (-72.0, True), (-80.0, False), (-88.0, False)):
        now = make_elements(turn, {**base, **_tap(np.radians(deg))})
        got = run_program(src, now, history_of(start, now))["turned_tap"]
        assert got[0] is ok, (deg, got)
    box = sandbox.Sandbox()
    box.start()
    try:
        coverage.check_path_coverage(src, turn.constraints, {e.id: e.points for e in els}, None, None, 0.0, box,
                                     deadline_s=2.0, reject_failing_at_start=True)
    finally:
        box.close()


def test_drag_stick_checks(make_elements, run_program) -> None:
    base = SCENES["drag-stick"]
    drag, src = _program("drag-stick", 1, make_elements, base)

    def run(**kw):
        return run_program(src, make_elements(drag, {**base, **_drag(**kw)}))

    assert run(stick_x=0.645)["behind_cube"][0]  # down beyond the cube: the target lies the other way
    assert not run(stick_x=0.58)["behind_cube"][0]  # down between the cube and the target
    assert not run(stick_x=0.645, cube=(0.6, 0.2, 0.02))["behind_cube"][0]  # past the shaft's end
    assert run(stick_x=0.58, low=False)["behind_cube"][0]  # still high: nothing to judge
    assert run(cube=(0.43, 0.01, 0.02))["ontarget_cube"][0] and not run(cube=(0.52, 0.0, 0.02))["ontarget_cube"][0]
    # the stick away from the grasp point: a drop, unless the cube is already on the target (the put-down)
    assert run(low=False)["dragheld_stick"][0]  # held (the tip is at its grip)

    def away(cube):
        return run_program(src, make_elements(drag, {**base, **_drag(cube=cube), **_robot([0.66, 0.35, 0.2])}))

    assert away((0.43, 0.01, 0.02))["dragheld_stick"][0] and not away((0.6, 0.0, 0.02))["dragheld_stick"][0]


def test_drag_stick_on_target_is_the_task_square_less_3_mm(make_elements, run_program) -> None:
    """The task counts the cube on the 10 cm target when its centre is inside the square; the kb's checks, 3 mm
    inside each side (the perception's point accuracy). A circle of 4 cm called drag-stick 88559109's cube off the
    target (3.91 and -1.26 cm along the sides, 4.1 cm from the centre) and the put-down at the drag's end a drop;
    the target turned about the vertical too (its sides are read from the surface's corners)."""
    base = SCENES["drag-stick"]
    drag, src = _program("drag-stick", 1, make_elements, base)
    centre = np.array([0.42, 0.0, 0.0])
    half = np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]]) * 0.05
    for yaw in (0.0, np.radians(30.0), np.radians(-75.0)):
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        sq = np.column_stack([centre[:2] + half @ R.T, np.zeros(4)])
        for along, ok in (((0.0391, -0.0126), True), ((0.03, 0.03), True), ((-0.045, 0.045), True),
                          ((0.049, 0.0), False), ((0.03, -0.052), False), ((0.0, 0.08), False)):
            cube = np.array([*(centre[:2] + R @ np.array(along)), 0.02])
            state = {**base, **_drag(cube=tuple(cube)), ("target", "surface"): sq, **_robot([0.66, 0.35, 0.2])}
            out = run_program(src, make_elements(drag, state))
            assert out["ontarget_cube"][0] is ok and out["dragheld_stick"][0] is ok, (np.degrees(yaw), along)


def test_sweep_to_dustpan_checks(make_elements, run_program) -> None:
    sweep, src = _program("sweep-to-dustpan", 1, make_elements, SCENES["sweep-to-dustpan"])
    for n, ok in ((5, True), (4, True), (3, False), (0, False)):
        assert run_program(src, make_elements(sweep, {**SCENES["sweep-to-dustpan"], **_pan(n)}))[
            "inpan_dustpan"][0] is ok
