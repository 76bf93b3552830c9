"""MonitorRuntime: start (validate -> coverage -> load), step, and verdict classification."""

from __future__ import annotations

import math

import pytest
from hostile_programs import GOOD

from code_as_monitor.core.constraints import Phase, Verdict
from code_as_monitor.core.errors import ProgramError, SandboxError
from code_as_monitor.monitor import (
    MonitorRuntime,
    any_during_violated,
    during_violations,
    faults,
    unmet_upon,
    upon_satisfied,
)
from code_as_monitor.monitor.perturb import TURNS_PER_ELEMENT


def _v(cid: str, phase: Phase, ok: bool, fault: bool = False) -> Verdict:
    return Verdict(cid, phase, ok, "r", math.nan, 0.0, fault)


def test_start_step_and_classify(constraints, scene):
    with MonitorRuntime(deadline_s=0.1, n_perturbations=32) as rt:
        report = rt.start(GOOD, constraints, scene, None, None, 0.0)
        assert report.ok and report.n_inputs == 33 + TURNS_PER_ELEMENT + 2
        v = rt.step(scene, None, None, 0.1)
        assert not any_during_violated(v) and upon_satisfied(v)
        dropped = {0: scene[0] + [0.0, 0.0, 0.3], 1: scene[1] - [0.0, 0.0, 0.15]}
        v = rt.step(dropped, None, None, 0.2)
        assert [x.constraint_id for x in during_violations(v)] == ["a"]
        assert not upon_satisfied(v) and [x.constraint_id for x in unmet_upon(v)] == ["b"]
        assert "m from the tip" in during_violations(v)[0].reason


def test_rejected_program_drops_the_previous_one(constraints, scene):
    with MonitorRuntime(deadline_s=0.1, n_perturbations=8) as rt:
        rt.start(GOOD, constraints, scene)
        with pytest.raises(ProgramError, match="'while'"):
            rt.start(GOOD + "\ndef f(x):\n    while x:\n        pass\n", constraints, scene)
        with pytest.raises(SandboxError, match="without a started program"):
            rt.step(scene, None, None, 0.0)
        with pytest.raises(ProgramError, match="path coverage failed"):
            rt.start(GOOD.replace("0.05", "0.01"), constraints, scene)  # during check fails at start
        rt.start(GOOD, constraints, scene)
        assert upon_satisfied(rt.step(scene, None, None, 0.0))


def test_faults_are_never_violations_nor_satisfactions():
    verdicts = [_v("a", Phase.DURING, False, fault=True), _v("b", Phase.UPON, False, fault=True)]
    assert not any_during_violated(verdicts) and not during_violations(verdicts)
    assert not upon_satisfied(verdicts) and len(unmet_upon(verdicts)) == 1 and len(faults(verdicts)) == 2
    assert upon_satisfied([_v("a", Phase.DURING, False)])  # no upon check: vacuously satisfied
    assert any_during_violated([_v("a", Phase.DURING, False), _v("b", Phase.UPON, True)])
