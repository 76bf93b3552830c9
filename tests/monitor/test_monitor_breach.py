"""The kernel layer and the host, end to end, after a full escape from the allow-list and the namespace.

The worker here is the real one with validation and the restricted namespace switched off
(``breached_worker.py``): each program of ``breach_programs.py`` holds the real builtins, ``os``,
``ctypes``, ``socket``, ``threading`` ... and tries to read or write files, run commands, kill, trace or
read the control process, open sockets, start threads, leave its namespaces, raise its limits, hang the
frame or flood what comes back. The seccomp filter, the namespaces and the resource limits must stop it
(a fault for that check, or the worker killed and the frame a fault), and the control process must come
out unharmed: not blocked past the deadline (generous slack), its arrays and memory as before, no
process it lost track of, nothing on its stderr, no file created, no secret in a reason.
"""

from __future__ import annotations

import math
import os
import re
import time

import numpy as np
import pytest
from breach_programs import BREACHES, DEFAULT, GOOD_B, SECRET_ENV, SYS
from breached_worker import BOOT, parse_only
from hostile_attacks import CANARY
from hostile_programs import GOOD
from hostutil import RSS_GROWTH_LIMIT, SLACK_S, live_children, rss_bytes, same, settled_children, snapshot

from code_as_monitor.monitor import process
from code_as_monitor.monitor import sandbox as sandbox_module
from code_as_monitor.monitor.protocol import _CONTROL, REASON_MAX
from code_as_monitor.monitor.sandbox import Sandbox


@pytest.fixture(scope="module")
def breached():
    """A confined sandbox whose workers run programs unvalidated with the real builtins."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(SECRET_ENV, "hunter2-do-not-leak")
        mp.delenv("CAM_ALLOW_UNCONFINED", raising=False)
        mp.setattr(process, "_BOOT", BOOT)
        mp.setattr(process, "SPAWN", "exec")  # a replaced boot line needs its own interpreter
        mp.setattr(sandbox_module, "validate_program", parse_only)
        with Sandbox(deadline_s=0.5, allow_unconfined=False) as sb:
            assert "seccomp" in sb.confinement and "no_new_privs" in sb.confinement, sb.confinement
            yield sb


def _clean(reason: str) -> bool:
    return (len(reason) <= REASON_MAX and not _CONTROL.search(reason)
            and not re.search(r"0x[0-9a-fA-F]{5,}", reason) and "hunter2" not in reason)


def _cases() -> list:
    return [pytest.param(*c, id=c[0], marks=[] if c[0] in DEFAULT else [pytest.mark.slow]) for c in BREACHES]


def test_the_breach_corpus_is_large_and_mixed():
    names = [c[0] for c in BREACHES]
    assert len(names) >= 50 and len(set(names)) == len(names)
    assert {c[2] for c in BREACHES} == {"fault", "frame", "either", "clean"}
    assert sum(c[4] == SYS for c in BREACHES) >= 15  # killed by the seccomp filter (SIGSYS)
    assert set(names) >= DEFAULT


@pytest.mark.parametrize(("name", "source", "kind", "needle", "ends"), _cases())
def test_breached_program_is_stopped_by_the_kernel_and_contained(name, source, kind, needle, ends, breached,
                                                                  constraints, scene, capfd):
    E = scene
    H = {i: np.stack([p + np.array([0.01 * k, 0.0, 0.0]) for k in range(4)]) for i, p in scene.items()}
    Ht = np.array([0.7, 0.8, 0.9, 1.0])
    before_e, before_h, before_t = snapshot(E), snapshot(H), Ht.copy()
    others = set(live_children()) - breached.all_pids
    breached.load(source, constraints)
    w = breached._active
    rss0 = rss_bytes()
    t0 = time.perf_counter()
    a, b = breached.evaluate(E, H, Ht, 1.0)
    assert time.perf_counter() - t0 < breached.deadline_s + SLACK_S  # never blocked past the deadline
    assert rss_bytes() - rss0 < RSS_GROWTH_LIMIT  # nothing the worker sent was kept
    assert _clean(a.reason) and _clean(b.reason), (a.reason, b.reason)
    assert math.isnan(a.margin) or math.isfinite(a.margin)
    if kind == "fault":
        assert a.fault and not a.ok and re.search(needle, a.reason), a
        assert (b.ok, b.fault, b.reason) == (True, False, "fine"), b
        assert breached.worker_pid == w.pid  # the worker lives on
    elif kind == "frame":
        assert a.fault and b.fault and not a.ok and not b.ok, (a, b)
        assert re.search(needle, a.reason), a.reason
        assert breached.worker_pid != w.pid
        if ends is not None:  # how it ended: the filter's SIGSYS for a forbidden system call
            assert w.proc.wait(timeout=10) == ends, (w.proc.returncode, w.how_it_ended())
    elif kind == "either":
        assert a.fault and not a.ok and re.search(needle, a.reason), a
    else:  # clean
        assert not a.fault and a.ok and needle in a.reason, a
    assert same(E, before_e) and same(H, before_h) and np.array_equal(Ht, before_t)  # the host's arrays
    ours = settled_children(others, lambda: breached.all_pids)
    assert ours <= breached.all_pids, (ours, breached.all_pids)
    assert not os.path.exists(CANARY)
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)


def test_state_planted_by_a_breached_program_does_not_reach_the_next_one(breached, constraints, scene):
    planter = ("def check_a(E, H, t):\n    b = __import__('builtins')\n    b.planted = True\n"
               "    __import__('numpy').pi = 3.0\n    __import__('sys').modules['math'].tau = 0.0\n"
               "    return True, 'planted'\n" + GOOD_B)
    innocent = ("def check_a(E, H, t):\n    p = hasattr(__import__('builtins'), 'planted')\n"
                "    ok = not p and np.pi > 3.1 and math.tau > 6.2\n"
                "    return ok, f'planted={p} pi={np.pi:.2f} tau={math.tau:.2f}'\n" + GOOD_B)
    breached.load(planter, constraints)
    assert breached.evaluate(scene, None, None, 0.0)[0].reason == "planted"
    breached.load(innocent, constraints)
    a, _ = breached.evaluate(scene, None, None, 0.0)
    assert a.ok and not a.fault and a.reason == "planted=False pi=3.14 tau=6.28", a


def test_a_good_program_after_the_breaches(breached, constraints, scene):
    breached.load(GOOD, constraints)
    a, b = breached.evaluate(scene, None, None, 1.0)
    assert (a.ok, a.fault, b.ok, b.fault) == (True, False, True, False), (a, b)
