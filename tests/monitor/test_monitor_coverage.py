"""White-box path coverage at subgoal start: crashing branches, dead branches, failing starts."""

from __future__ import annotations

import numpy as np
import pytest
from hostile_programs import GOOD

from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.coverage import CoverageError, check_path_coverage
from code_as_monitor.monitor.instrument import instrument
from code_as_monitor.monitor.perturb import DEPARTURES_PER_ELEMENT, TURNS_PER_ELEMENT, YAW_TURNS, make_probes
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.validate import validate_program

B = '''

def check_b(E, H, t):
    return bool(E[1][:, 2].mean() > 0.1), "height"
'''


def _a(body: str) -> str:
    lines = "\n".join("    " + line for line in body.strip("\n").splitlines())
    return f"def check_a(E, H, t):\n{lines}\n" + B


CRASHING_BRANCH = _a('''
d = distance(E[0], E[1])
if d > 0.1:
    return False, "block dropped, " + d
return True, "attached"
''')

DEAD_BRANCH = _a('''
d = distance(E[0], E[1])
if d < 0:
    return False, "negative distance"
return d < 0.05, "attached"
''')

NON_BOOL_BRANCH = _a('''
d = distance(E[0], E[1])
if len(H.t) < 2:
    return "maybe", "no history yet"
return d < 0.05, "attached"
''')

FAILS_AT_START = _a('''
d = distance(E[0], E[1])
return d < 0.01, f"{d:.3f} m from the tip"
''')

NEVER_HOLDS = _a('''
d = distance(E[0], E[1])
return d < -1.0, f"{d:.3f} m from the tip"
''')

UPON_FALSE_AT_START = """
def check_a(E, H, t):
    d = distance(E[0], E[1])
    return d < 0.05, f"{d:.3f} m from the tip"

def check_b(E, H, t):
    h = E[1][:, 2].mean()
    return bool(h > 0.21), f"height {h:.3f} m"
"""

LOOPS_WHEN_FAR = _a('''
d = distance(E[0], E[1])
if d > 0.15:
    for i in range(10 ** 12):
        pass
return d < 0.05, "attached"
''')

ELIF_AND_TERNARY = _a('''
d = distance(E[0], E[1])
n = normal(E[1])
level = "level" if angle_to_vertical(n) < 0.3 else "tilted"
if d > 0.1:
    return False, f"far, {level}"
elif d > 0.05:
    return False, f"slipping, {level}"
for i in range(len(H.t) - 1):
    if displacement(H[1][i:i + 2]) > 0.05:
        return False, "jerk"
return True, f"attached, {level}"
''')


def _run(source, constraints, scene, sandbox, **kw):
    return check_path_coverage(source, constraints, scene, None, None, 1.0, sandbox, **kw)


def test_good_program_passes_with_full_coverage(sandbox, constraints, scene):
    report = _run(GOOD, constraints, scene, sandbox)
    assert report.ok and report.fraction == 1.0
    assert report.covered == {b.id for b in report.branches}
    assert report.n_inputs == 97 + TURNS_PER_ELEMENT + 2 + 2 * DEPARTURES_PER_ELEMENT + 2 + YAW_TURNS
    # state, 96 perturbations, turns, 2 meetings, the departures of 2 elements, 2 placements, turns about the vertical
    assert {b.kind for b in report.branches} == {"entry", "if-true", "if-false"}


def test_elif_for_and_ternary_branches_are_all_driven(sandbox, constraints, scene):
    report = _run(ELIF_AND_TERNARY, constraints, scene, sandbox)
    kinds = sorted(b.kind for b in report.branches)
    assert kinds.count("if-true") == 3 and "for-body" in kinds and "ifexp-false" in kinds
    assert report.fraction == 1.0


def test_crashing_branch_is_caught_with_its_input(sandbox, constraints, scene):
    with pytest.raises(CoverageError) as err:
        _run(CRASHING_BRANCH, constraints, scene, sandbox)
    msg = str(err.value)
    assert "check_a: raised TypeError" in msg and "(input " in msg
    assert isinstance(err.value, ProgramError) and err.value.report.faults


def test_unreachable_branch_is_reported_not_rejected(sandbox, constraints, scene):
    report = _run(DEAD_BRANCH, constraints, scene, sandbox)
    assert report.ok and [b.line for b in report.unreached] == [3] and report.fraction < 1.0
    assert "check_a, line 3: the 'if' condition is never true" in report.message()
    assert report.message().startswith("path coverage passed")
    with pytest.raises(CoverageError) as err:  # still available as a stricter setting
        _run(DEAD_BRANCH, constraints, scene, sandbox, require_full_coverage=True)
    assert "check_a, line 3: the 'if' condition is never true" in str(err.value)


def test_non_bool_result_on_a_rare_branch(sandbox, constraints, scene):
    H = {i: np.repeat(p[None], 5, axis=0) for i, p in scene.items()}
    with pytest.raises(CoverageError, match=r"ok must be a bool, got str \(input \d+: .*T=1"):
        check_path_coverage(NON_BOOL_BRANCH, constraints, scene, H, np.linspace(0.6, 1.0, 5), 1.0, sandbox)


def test_during_check_failing_at_start_is_a_violation_not_a_bad_program(sandbox, constraints, scene):
    """False on the starting state but True on some perturbation: the program works and the world violates
    its constraint. Accepted, with the starting verdict kept for the agent to raise as an alarm."""
    report = _run(FAILS_AT_START, constraints, scene, sandbox)
    assert report.ok and report.outcomes["check_a"][0] > 0 and report.outcomes["check_a"][1] > 0
    assert [(v.constraint_id, v.ok, v.fault, v.reason) for v in report.violated_at_start] == [
        ("a", False, False, "0.020 m from the tip")]
    assert report.violated_at_start[0].t == 1.0
    assert report.failing_at_start == ["check_a: returned False, '0.020 m from the tip'"]
    assert report.message().startswith("path coverage passed") and "reported as an alarm" in report.message()
    with pytest.raises(CoverageError) as err:  # the old rule, kept as a stricter setting
        _run(FAILS_AT_START, constraints, scene, sandbox, reject_failing_at_start=True)
    assert "already fail on the starting state" in str(err.value)
    assert "check_a: returned False, '0.020 m from the tip'" in str(err.value)
    assert "check_b" not in str(err.value)  # an upon check may well be False at the start


def test_upon_check_false_at_start_is_not_a_violation(sandbox, constraints, scene):
    report = _run(UPON_FALSE_AT_START, constraints, scene, sandbox)
    assert report.outcomes["check_b"][1] > 0 and report.outcomes["check_b"][0] > 0
    assert report.ok and not report.violated_at_start and not report.failing_at_start


def test_during_check_that_can_never_hold_is_still_rejected(sandbox, constraints, scene):
    """False on the starting state and on every perturbation: not a violation to report but a check that
    can never be satisfied; the coder gets it back."""
    with pytest.raises(CoverageError) as err:
        _run(NEVER_HOLDS, constraints, scene, sandbox)
    msg = str(err.value)
    assert "check_a: returned False on all" in msg and "can never be satisfied" in msg
    assert err.value.report.violated_at_start  # recorded, but the constant answer is what rejects it


def test_overrun_on_a_branch_stops_early(constraints, scene):
    with Sandbox(deadline_s=0.02) as sb, pytest.raises(CoverageError) as err:
        _run(LOOPS_WHEN_FAR, constraints, scene, sb, deadline_s=0.05)
    msg = str(err.value)
    assert "deadline 50 ms exceeded" in msg and "stopped after 2 overruns" in msg
    sb_report = err.value.report
    assert sb_report.n_inputs < 97 and not sb_report.unreached


def test_factory_and_rejection_before_running(constraints, scene):
    report = _run(GOOD, constraints, scene, lambda: Sandbox(deadline_s=0.1), n_perturbations=32)
    assert report.n_inputs == 33 + TURNS_PER_ELEMENT + 2 + 2 * DEPARTURES_PER_ELEMENT + 2 + YAW_TURNS  # 2 elements
    with pytest.raises(ProgramError, match="'while'"):
        _run(GOOD + "\ndef f():\n    while True:\n        pass\n", constraints, scene, None)


def test_probes_are_consistent_and_deterministic(scene):
    H = {i: np.repeat(p[None], 5, axis=0) for i, p in scene.items()}
    Ht = np.linspace(0.0, 0.4, 5)
    probes = make_probes(scene, H, Ht, 0.4, n=40, seed=3)
    assert len(probes) == 41 + TURNS_PER_ELEMENT + 2 + 2 * DEPARTURES_PER_ELEMENT + 2 + YAW_TURNS
    assert probes[0].description.startswith("the current state")
    assert [p.description for p in probes] == [p.description for p in make_probes(scene, H, Ht, 0.4, 40, 3)]
    for p in probes:
        T = len(p.history_t)
        assert set(p.elements) == set(p.history) == {0, 1}
        for i in (0, 1):
            assert p.elements[i].shape == scene[i].shape and p.history[i].shape == (T, *scene[i].shape)
            np.testing.assert_allclose(p.history[i][-1], p.elements[i], atol=1e-12)
    lengths = {len(p.history_t) for p in probes}
    assert 1 in lengths and 5 in lengths
    assert any("piled" in p.description for p in probes) and any("rotated" in p.description for p in probes)
    turns = [p for p in probes if "turned" in p.description]
    # the surface (element 1) turned into its current pose about random axes, then about the vertical at angles one
    # from each stratum of 0.2 rad to a quarter-turn; the point never
    assert len(turns) == TURNS_PER_ELEMENT + YAW_TURNS
    for p in turns:
        first, last = p.history[1][0], p.history[1][-1]
        assert not np.allclose(first, last) and np.allclose(first.mean(axis=0), last.mean(axis=0))
    yaws = [abs(float(p.description.split(" turned ")[1].split(" deg")[0])) for p in turns[-YAW_TURNS:]]
    edges = np.degrees(np.linspace(0.2, np.pi / 2, YAW_TURNS + 1))
    assert all(lo - 0.5 <= y <= hi + 0.5 for y, lo, hi in zip(yaws, edges[:-1], edges[1:])), yaws
    for p in turns[-YAW_TURNS:]:
        np.testing.assert_allclose(p.history[1][0][:, 2], p.history[1][-1][:, 2], atol=1e-12)  # about the vertical
    meets = [p for p in probes if "moved since the oldest frame" in p.description]
    assert len(meets) == 2  # each element carried to the other (a block to the suction tip)
    for p in meets:
        a = int(p.description.split()[1])
        np.testing.assert_allclose(p.history[a][0], scene[a], atol=1e-12)  # it began where it was
        assert np.linalg.norm(p.elements[a].mean(axis=0)[:2] - p.elements[1 - a].mean(axis=0)[:2]) < 1e-9
    gone = [p for p in probes if "moved away" in p.description]
    assert len(gone) == 2 * DEPARTURES_PER_ELEMENT  # each element knocked away while the other stayed
    for p in gone:
        a = int(p.description.split()[1])
        np.testing.assert_allclose(p.history[a][0], scene[a], atol=1e-12)  # it began where it is in the scene
        np.testing.assert_allclose(p.elements[1 - a], scene[1 - a], atol=1e-12)  # the other stayed
        assert 0.04 - 1e-9 <= np.linalg.norm(p.elements[a].mean(axis=0) - scene[a].mean(axis=0)) <= 0.3 + 1e-9
    placed = [p for p in probes if "placed" in p.description]
    assert len(placed) == 2  # element 0 above element 1 and element 1 above element 0
    for p, (i, j) in zip(placed, [(0, 1), (1, 0)]):
        np.testing.assert_allclose(p.elements[i].mean(axis=0)[:2], scene[j].mean(axis=0)[:2], atol=1e-12)
        gap = p.elements[i][:, 2].min() - scene[j][:, 2].max()
        assert 0.01 <= gap <= 0.06


def test_instrumentation_is_deterministic_and_marker_is_unspellable(constraints):
    tree = validate_program(ELIF_AND_TERNARY, constraints)
    assert instrument(tree)[1] == instrument(validate_program(ELIF_AND_TERNARY, constraints))[1]
    with pytest.raises(ProgramError, match="__cam_cov__"):
        validate_program(GOOD.replace('"block attached"', '__cam_cov__(0, "x")'), constraints)


ALWAYS_TRUE = _a('''
d = distance(E[0], E[1])
if d >= 0.0:
    return True, f"attached ({d:.3f} m)"
return False, "detached"
''')

NEVER_TRUE = '''
def check_a(E, H, t):
    return distance(E[0], E[1]) < 0.05, "attached"


def check_b(E, H, t):
    h = E[1][:, 2].mean()
    return bool(h > 100.0), f"block at {h:.2f} m"
'''


def test_a_check_that_can_never_fail_or_never_hold_is_rejected(sandbox, constraints, scene):
    with pytest.raises(CoverageError) as err:
        _run(ALWAYS_TRUE, constraints, scene, sandbox)
    report = err.value.report
    assert report.outcomes["check_a"][1] == 0 and report.outcomes["check_a"][0] == report.n_inputs
    assert "check_a: returned True on all" in str(err.value) and "never report a violation" in str(err.value)
    assert "check_a, line 3: the 'if' condition is never false" in str(err.value)  # also listed
    with pytest.raises(CoverageError) as err:
        _run(NEVER_TRUE, constraints, scene, sandbox)
    assert "check_b: returned False on all" in str(err.value) and "never be satisfied" in str(err.value)
    assert "check_a" not in str(err.value).split("never changes")[1]


STAYS_OR_HELD = _a('''
m = displacement(H[1])
d = distance(E[0], centroid(E[1]))
if m <= 0.02 or d <= 0.03:
    return True, "in place or in the gripper"
return False, "moved while the gripper approached"
''')


def test_a_stays_or_held_check_is_covered_when_the_gripper_starts_at_the_object(sandbox, constraints, scene,
                                                                               monkeypatch):
    """A re-grasp starts with the tip at the object: only a departure (the object moved away since the oldest
    frame, the tip stayed) both moves the object and takes it from the tip, so without it the check reads as
    one that can never fail (a pen re-grasped in its holder was re-planned 22 times at one instant)."""
    at_tip = {0: scene[1].mean(axis=0, keepdims=True) + np.array([[0.0, 0.0, 0.01]]), 1: scene[1]}
    report = _run(STAYS_OR_HELD, constraints, at_tip, sandbox)
    assert report.ok and report.outcomes["check_a"][1] > 0
    monkeypatch.setattr("code_as_monitor.monitor.perturb.DEPARTURES_PER_ELEMENT", 0)
    with pytest.raises(CoverageError, match="check_a: returned True on all"):
        _run(STAYS_OR_HELD, constraints, at_tip, sandbox)
