"""Legitimate programs in the styles a VLM writes pass the full runtime path (validation, path coverage,
a fresh confined worker) and give the right verdicts on constructed states."""

from __future__ import annotations

import pytest
from legit_programs import LEGIT

from code_as_monitor.monitor.runtime import MonitorRuntime


@pytest.fixture(scope="module")
def runtime():
    with MonitorRuntime(deadline_s=0.25) as rt:
        yield rt


def test_there_are_enough_programs():
    assert len(LEGIT) >= 20 and len({c[0] for c in LEGIT}) == len(LEGIT)


@pytest.mark.parametrize(("name", "constraints", "source", "start", "checks"), LEGIT, ids=[c[0] for c in LEGIT])
def test_legit_program_is_accepted_and_right(name, constraints, source, start, checks, runtime):
    report = runtime.start(source, constraints, start, None, None, 0.0)
    assert report.ok, report.message()
    if name.startswith("unreached_"):
        assert report.unreached, "the guard was expected to be unreached (reported, not rejected)"
        assert "reported, not a reason to reject" in report.message()
    for n_true, n_false in report.outcomes.values():
        assert n_true and n_false  # every check answered both ways over the probes
    for (E, H, Ht, t), expected in checks:
        verdicts = runtime.step(E, H, Ht, t)
        assert [v.constraint_id for v in verdicts] == [c.id for c in constraints]
        assert not any(v.fault for v in verdicts), verdicts
        assert [v.ok for v in verdicts] == expected, verdicts
        assert all(v.reason and len(v.reason) <= 300 for v in verdicts)
