"""MonitorRuntime: start (validate -> coverage -> load), step, and verdict classification."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hostile_programs import GOOD

from code_as_monitor.core.constraints import Constraint, Phase, Verdict
from code_as_monitor.core.errors import ProgramError, SandboxError
from code_as_monitor.monitor import (
    MonitorRuntime,
    any_during_violated,
    during_violations,
    faults,
    unmet_upon,
    upon_satisfied,
)
from code_as_monitor.monitor.perturb import DEPARTURES_PER_ELEMENT, TURNS_PER_ELEMENT, YAW_TURNS


def _v(cid: str, phase: Phase, ok: bool, fault: bool = False) -> Verdict:
    return Verdict(cid, phase, ok, "r", math.nan, 0.0, fault)


def test_start_step_and_classify(constraints, scene):
    with MonitorRuntime(deadline_s=0.1, n_perturbations=32) as rt:
        report = rt.start(GOOD, constraints, scene, None, None, 0.0)
        assert report.ok and report.n_inputs == 33 + TURNS_PER_ELEMENT + 2 + 2 * DEPARTURES_PER_ELEMENT + 2 + YAW_TURNS
        v = rt.step(scene, None, None, 0.1)
        assert not any_during_violated(v) and upon_satisfied(v)
        dropped = {0: scene[0] + [0.0, 0.0, 0.3], 1: scene[1] - [0.0, 0.0, 0.15]}
        v = rt.step(dropped, None, None, 0.2)
        assert [x.constraint_id for x in during_violations(v)] == ["a"]
        assert not upon_satisfied(v) and [x.constraint_id for x in unmet_upon(v)] == ["b"]
        assert "m from the tip" in during_violations(v)[0].reason


def test_rejected_program_drops_the_previous_one(constraints, scene):
    with MonitorRuntime(deadline_s=0.1, n_perturbations=32) as rt:
        rt.start(GOOD, constraints, scene)
        with pytest.raises(ProgramError, match="'while'"):
            rt.start(GOOD + "\ndef f(x):\n    while x:\n        pass\n", constraints, scene)
        with pytest.raises(SandboxError, match="without a started program"):
            rt.step(scene, None, None, 0.0)
        with pytest.raises(ProgramError, match="path coverage failed"):
            rt.start(GOOD.replace("0.05", "-1.0"), constraints, scene)  # during check can never hold
        with pytest.raises(SandboxError, match="without a started program"):
            rt.step(scene, None, None, 0.0)
        rt.start(GOOD, constraints, scene)
        assert upon_satisfied(rt.step(scene, None, None, 0.0))


def test_a_during_check_violated_at_start_is_loaded_and_reported(constraints, scene):
    """The world already violates the constraint (the block is 2 cm from the tip, the check allows 1 cm): the
    program is accepted and loaded, the report carries the starting violation, and step says the same."""
    strict = GOOD.replace("0.05", "0.01")
    with MonitorRuntime(deadline_s=0.1, n_perturbations=32) as rt:
        report = rt.start(strict, constraints, scene, None, None, 0.5)
        assert report.ok and [(v.constraint_id, v.reason) for v in report.violated_at_start] == [
            ("a", "block is 0.020 m from the tip")]
        v = rt.step(scene, None, None, 0.6)
        assert [(x.constraint_id, x.reason) for x in during_violations(v)] == [("a", "block is 0.020 m from the tip")]
    with MonitorRuntime(deadline_s=0.1, n_perturbations=32, reject_failing_at_start=True) as rt, \
            pytest.raises(ProgramError, match="already fail on the starting state"):
        rt.start(strict, constraints, scene)


def test_faults_are_never_violations_nor_satisfactions():
    verdicts = [_v("a", Phase.DURING, False, fault=True), _v("b", Phase.UPON, False, fault=True)]
    assert not any_during_violated(verdicts) and not during_violations(verdicts)
    assert not upon_satisfied(verdicts) and len(unmet_upon(verdicts)) == 1 and len(faults(verdicts)) == 2
    assert upon_satisfied([_v("a", Phase.DURING, False)])  # no upon check: vacuously satisfied
    assert any_during_violated([_v("a", Phase.DURING, False), _v("b", Phase.UPON, True)])


def test_non_finite_points_make_elements_stale_never_a_pass(scene):
    cs = [Constraint("a", "block stays on the tip", Phase.DURING, element_ids=[0, 1]),
          Constraint("b", "block lifted", Phase.UPON, element_ids=[1]),
          Constraint("c", "tip above the table", Phase.DURING, element_ids=[0])]
    src = GOOD + "\n\ndef check_c(E, H, t):\n    z = E[0][0, 2]\n    return bool(z > 0.0), f'tip at {z:.2f} m', z\n"
    with MonitorRuntime(deadline_s=0.2, n_perturbations=32) as rt:
        rt.start(src, cs, scene)
        for bad in (np.nan, np.inf, -np.inf):
            block = scene[1].copy()
            block[2, 1] = bad
            a, b, c = rt.step({0: scene[0], 1: block}, None, None, 1.0)
            assert rt.stale_elements == {1}
            for v in (a, b):
                assert v.fault and not v.ok and v.reason.startswith("stale:"), v
            assert c.ok and not c.fault  # it does not read element 1
            assert not any_during_violated([a, b, c]) and not upon_satisfied([a, b, c])
        H = {i: np.repeat(p[None], 3, axis=0) for i, p in scene.items()}
        H[0][0, 0, 2] = np.nan  # an old frame of the tip
        verdicts = rt.step(scene, H, np.array([0.8, 0.9, 1.0]), 1.0)
        assert rt.stale_elements == {0} and all(v.fault for v in verdicts if v.constraint_id in ("a", "c"))
        verdicts = rt.step(scene, None, None, float("nan"))
        assert all(v.fault and v.reason.startswith("stale:") for v in verdicts)
        verdicts = rt.step(scene, None, None, 1.1)  # finite again: verdicts again
        assert rt.stale_elements == set() and not any(v.fault for v in verdicts)


def test_non_finite_margin_or_non_bool_ok_is_a_fault(scene):
    cs = [Constraint("a", "x", Phase.DURING), Constraint("b", "y", Phase.UPON)]
    src = ("def check_a(E, H, t):\n    return True, 'inf margin', math.inf\n\n"
           "def check_b(E, H, t):\n    return 1, 'one'\n")
    from code_as_monitor.monitor.sandbox import Sandbox

    with Sandbox(deadline_s=5.0) as sb:  # generous: the first frame on a loaded machine
        sb.load(src, cs)
        a, b = sb.evaluate(scene, None, None, 0.0)
    assert a.fault and not a.ok and "not finite" in a.reason
    assert b.fault and not b.ok and "ok must be a bool" in b.reason


SET_CHECK = '''
def check_enough_in(E, H, t):
    present = [i for i in (1, 2, 3, 4) if i in E]
    n = count_in_polygon([E[i] for i in present], E[0])
    if n >= 2:
        return True, "%d of the blocks seen are inside" % n, n - 1.5
    return False, "only %d of the blocks seen are inside" % n, n - 1.5
'''


def test_a_check_over_monotone_members_runs_on_the_members_given():
    """The agent runs a check whose monotone members are stale on the elements seen (``Constraint.monotone``): the
    sandbox takes frames with fewer elements than the program started with, and the full set again after."""
    from code_as_monitor.core.elements import ElementSpec

    parts = [ElementSpec("zone", "zone", "surface", "surface")] + [ElementSpec(f"b{i}", f"block_{i}") for i in range(4)]
    c = Constraint("enough_in", "at least 2 blocks in the zone", Phase.UPON, parts, element_ids=[0, 1, 2, 3, 4],
                   monotone=[f"block_{i}" for i in range(4)])
    zone = np.array([[0, 0, 0], [0.2, 0, 0], [0.2, 0.2, 0], [0, 0.2, 0]], float)
    pts = {0: zone, 1: np.array([[0.05, 0.05, 0.01]]), 2: np.array([[0.1, 0.1, 0.01]]),
           3: np.array([[0.5, 0.5, 0.01]]), 4: np.array([[0.15, 0.1, 0.01]])}
    H = {i: np.stack([p, p]) for i, p in pts.items()}
    ht = np.array([0.0, 0.1])

    def without(*gone):
        return {i: p for i, p in pts.items() if i not in gone}, {i: h for i, h in H.items() if i not in gone}

    assert c.monotone_element_ids() == {1, 2, 3, 4}
    with MonitorRuntime(deadline_s=0.5, n_perturbations=16) as rt:
        assert rt.start(SET_CHECK, [c], pts, H, ht, 0.1).ok
        (v,) = rt.step(pts, H, ht, 0.2)
        assert v.ok and not v.fault and v.reason.startswith("3 of")
        (v,) = rt.step(*without(2, 4), ht, 0.3)
        assert not v.ok and not v.fault and "only 1" in v.reason
        (v,) = rt.step(*without(4), ht, 0.4)
        assert v.ok and not v.fault and v.reason.startswith("2 of")
        (v,) = rt.step(pts, H, ht, 0.5)
        assert v.ok and v.reason.startswith("3 of")
