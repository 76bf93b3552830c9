"""The hostile/broken program corpus: each is rejected statically or contained as a fault, and the
sandbox keeps evaluating a good program correctly afterwards."""

from __future__ import annotations

import pytest
from hostile_programs import CORPUS, GOOD

from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.validate import validate_program


def test_corpus_is_large_and_mixed():
    assert len(CORPUS) >= 30
    assert len({name for name, *_ in CORPUS}) == len(CORPUS)
    kinds = {expected for _, _, expected, _ in CORPUS}
    assert kinds == {"rejected", "fault"}


def _assert_good_still_works(sandbox, constraints, scene):
    sandbox.load(GOOD, constraints)
    a, b = sandbox.evaluate(scene, None, None, 1.0)
    assert (a.ok, a.fault, b.ok, b.fault) == (True, False, True, False), (a, b)
    assert a.margin == pytest.approx(0.03)
    assert a.reason == "block attached"


@pytest.mark.parametrize(("name", "source", "expected", "needle"), CORPUS, ids=[c[0] for c in CORPUS])
def test_hostile_program_is_rejected_or_contained(name, source, expected, needle, sandbox, constraints, scene):
    if expected == "rejected":
        with pytest.raises(ProgramError) as err:
            validate_program(source, constraints)
        assert needle in str(err.value)
        assert "line" in str(err.value) or "missing" in str(err.value)
        with pytest.raises(ProgramError):  # the sandbox refuses it too, before sending anything
            sandbox.load(source, constraints)
    else:
        validate_program(source, constraints)
        sandbox.load(source, constraints)
        a, b = sandbox.evaluate(scene, None, None, 1.0)
        assert a.fault and not a.ok, a
        assert needle in a.reason, a.reason
        assert a.constraint_id == "a"
        if "deadline" not in a.reason:  # an exception or bad result faults only its own check
            assert (b.ok, b.fault, b.reason, b.margin) == (True, False, "fine", 1.0)
    _assert_good_still_works(sandbox, constraints, scene)
