"""Hostile programs (two corpora): each is rejected statically or contained as a fault verdict, and after
each one the control process is checked: it was not blocked past the deadline (generous slack), its
input arrays are unchanged, its memory did not grow with what the program returned, no worker process
leaked, nothing reached its stderr, and no file was created.

The slow part of the second corpus (deadline overruns and crashes, which cost a worker restart each) is
marked ``slow``; one of each kind stays in the default suite.
"""

from __future__ import annotations

import os
import re
import time

import numpy as np
import pytest
from hostile_attacks import ALL, CANARY
from hostile_kinds import KINDS
from hostile_programs import CORPUS, GOOD
from hostutil import RSS_GROWTH_LIMIT, SLACK_S, live_children, rss_bytes, same, settled_children, snapshot

from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.protocol import _CONTROL, REASON_MAX
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.validate import validate_program

DEFAULT_FRAME_CASES = {"loop_billion", "hash_deep_tuple"}
"""The whole-frame cases kept in the default suite; the other ones are ``slow``."""


def _cases() -> list:
    # the first corpus says "fault" for its deadline cases: they fault the whole frame
    out = [pytest.param(n, src, "frame" if needle == "deadline" else kind, needle, id=f"v1-{n}")
           for n, src, kind, needle in CORPUS]
    for c in ALL + KINDS:
        marks = [pytest.mark.slow] if c[2] in ("frame", "either") and c[0] not in DEFAULT_FRAME_CASES else []
        out.append(pytest.param(*c, id=c[0], marks=marks))
    return out


@pytest.fixture(scope="module")
def box():
    with Sandbox(deadline_s=0.5) as sb:
        yield sb


@pytest.fixture
def frame(scene):
    H = {i: np.stack([p + np.array([0.01 * k, 0.0, 0.0]) for k in range(4)]) for i, p in scene.items()}
    return scene, H, np.array([0.7, 0.8, 0.9, 1.0])


def test_corpora_are_large_and_mixed():
    assert len(ALL) >= 100 and len({c[0] for c in ALL}) == len(ALL)
    assert not {c[0] for c in ALL} & {c[0] for c in CORPUS}
    assert {c[2] for c in ALL} == {"rejected", "fault", "frame", "either", "bounded", "load", "clean"}
    assert sum(c[2] != "rejected" for c in ALL) >= 60  # most of the new ones reach the worker
    names = {c[0] for c in ALL + KINDS + CORPUS}
    assert len(names) == len(ALL) + len(KINDS) + len(CORPUS)


def _clean(reason: str) -> bool:
    return (len(reason) <= REASON_MAX and not _CONTROL.search(reason)
            and not re.search(r"0x[0-9a-fA-F]{5,}", reason))


@pytest.mark.parametrize(("name", "source", "kind", "needle"), _cases())
def test_hostile_program_is_rejected_or_contained(name, source, kind, needle, box, constraints, frame, capfd):
    E, H, Ht = frame
    before_e, before_h, before_t = snapshot(E), snapshot(H), Ht.copy()
    rss0 = rss_bytes()
    others = set(live_children()) - box.all_pids  # children of this process that are not this sandbox's
    if kind == "rejected":
        with pytest.raises(ProgramError) as err:
            validate_program(source, constraints)
        assert needle in str(err.value)
        assert "line" in str(err.value) or "missing" in str(err.value)
        with pytest.raises(ProgramError):  # the sandbox refuses it too, before any worker sees it
            box.load(source, constraints)
    elif kind == "load":
        with pytest.raises(ProgramError) as err:
            box.load(source, constraints)
        assert needle in str(err.value), str(err.value)
        assert _clean(str(err.value).splitlines()[-1][-REASON_MAX:])
    else:
        validate_program(source, constraints)
        box.load(source, constraints)
        pid = box.worker_pid
        t0 = time.perf_counter()
        a, b = box.evaluate(E, H, Ht, 1.0)
        assert time.perf_counter() - t0 < box.deadline_s + SLACK_S  # never blocked past the deadline
        assert a.constraint_id == "a" and b.constraint_id == "b"
        assert _clean(a.reason) and _clean(b.reason), (a.reason, b.reason)
        assert np.isnan(a.margin) or np.isfinite(a.margin)
        if kind == "fault":
            assert a.fault and not a.ok and needle in a.reason, a
            assert (b.ok, b.fault, b.reason, b.margin) == (True, False, "fine", 1.0)  # only its own check
        elif kind == "frame":
            assert a.fault and b.fault and not a.ok and not b.ok, (a, b)
            assert needle in a.reason, a.reason
            assert box.worker_pid != pid  # the worker was killed (or died) and replaced
        elif kind == "either":
            assert a.fault and not a.ok and re.search(needle, a.reason), a
            whole = "deadline" in a.reason or "died" in a.reason
            assert b.fault if whole else (b.ok and not b.fault), (a, b)
        elif kind == "bounded":  # contained either way: a fault of its own, or a result whose reason was cut
            assert (a.fault and not a.ok and re.search(needle, a.reason)) or (a.ok and len(a.reason) <= REASON_MAX), a
            assert b.ok or b.fault, b
        else:  # clean
            assert not a.fault and a.ok and needle in a.reason, a
    # the host after the attack
    assert same(E, before_e) and same(H, before_h) and np.array_equal(Ht, before_t)
    assert rss_bytes() - rss0 < RSS_GROWTH_LIMIT
    ours = settled_children(others, lambda: box.all_pids, most=box.n_spares + 2)
    assert ours <= box.all_pids, (ours, box.all_pids)  # no worker the sandbox lost track of
    assert len(ours) <= box.n_spares + 2  # the running worker, the spares, one being killed
    assert not os.path.exists(CANARY)
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)


def test_good_program_after_the_corpora(box, constraints, scene):
    box.load(GOOD, constraints)
    a, b = box.evaluate(scene, None, None, 1.0)
    assert (a.ok, a.fault, b.ok, b.fault) == (True, False, True, False), (a, b)
    assert a.margin == pytest.approx(0.03) and a.reason == "block attached"


def test_planted_state_does_not_reach_the_next_program(box, constraints, scene):
    planter = "SEEN = []\n\ndef check_a(E, H, t):\n    SEEN.append(1)\n    return len(SEEN) < 3, f'n={len(SEEN)}'\n"
    innocent = "SEEN = []\n\ndef check_a(E, H, t):\n    return len(SEEN) == 0, f'n={len(SEEN)}'\n"
    tail = "\n\ndef check_b(E, H, t):\n    return True, 'fine'\n"
    box.load(planter + tail, constraints)
    for _ in range(5):
        box.evaluate(scene, None, None, 1.0)
    assert box.evaluate(scene, None, None, 1.0)[0].reason == "n=6"
    box.load(innocent + tail, constraints)
    a, _ = box.evaluate(scene, None, None, 1.0)
    assert a.ok and a.reason == "n=0"
