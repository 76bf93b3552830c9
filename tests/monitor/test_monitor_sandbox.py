"""The sandbox worker: verdicts, history, deadlines, crashes and replacement."""

from __future__ import annotations

import contextlib
import math
import os
import signal
import time

import numpy as np
import pytest
from hostile_programs import GOOD
from hostutil import SLACK_S, wait_gone

from code_as_monitor.core.constraints import Constraint, Phase
from code_as_monitor.core.errors import ProgramError, SandboxError
from code_as_monitor.monitor.sandbox import Sandbox

HISTORY = '''
def check_a(E, H, t):
    T = len(H.t)
    moved = displacement(H[1])
    return T == 3 and H[1].shape == (3, 4, 3), f"T={T} moved={moved:.2f} dt={t - H.t[0]:.1f}", moved


def check_b(E, H, t):
    return E[0].shape == (1, 3), "shape"
'''

LOOP_ON_FAR = '''
def check_a(E, H, t):
    if distance(E[0], E[1]) > 1.0:
        for i in range(10 ** 12):
            pass
    return True, "near"


def check_b(E, H, t):
    return True, "fine"
'''


def test_verdicts_in_constraint_order(sandbox, constraints, scene):
    sandbox.load(GOOD, constraints)
    assert sandbox.worker_pid not in (None, os.getpid())
    a, b = sandbox.evaluate(scene, None, None, 2.5)
    assert (a.constraint_id, a.phase, b.constraint_id, b.phase) == ("a", Phase.DURING, "b", Phase.UPON)
    assert type(a.ok) is bool and type(b.ok) is bool  # numpy bool_ converted
    assert a.t == b.t == 2.5 and math.isnan(b.margin)
    far = {0: scene[0] + [0.0, 0.0, 0.1], 1: scene[1]}
    a, _ = sandbox.evaluate(far, None, None, 2.6)
    assert not a.ok and not a.fault and a.margin < 0 and "0.120 m" in a.reason


def test_history_and_timestamps(sandbox, constraints, scene):
    sandbox.load(HISTORY, constraints)
    H = {i: np.stack([p + np.array([0.1 * k, 0.0, 0.0]) for k in (-2, -1, 0)]) for i, p in scene.items()}
    a, b = sandbox.evaluate(scene, H, np.array([1.0, 1.5, 2.0]), 2.0)
    assert a.ok and not a.fault, a.reason
    assert a.reason == "T=3 moved=0.20 dt=1.0" and a.margin == pytest.approx(0.2)
    assert b.ok
    a, _ = sandbox.evaluate(scene, None, None, 2.0)  # no history: T = 1
    assert not a.ok and a.reason.startswith("T=1")
    assert scene[0].flags.writeable  # the caller's arrays are untouched


def test_deadline_kills_replaces_and_never_blocks(constraints, scene):
    far = {0: scene[0] + 5.0, 1: scene[1]}
    with Sandbox(deadline_s=0.03) as sb:
        sb.load(LOOP_ON_FAR, constraints)
        assert all(v.ok for v in sb.evaluate(scene, None, None, 0.0))
        pid = sb.worker_pid
        t0 = time.perf_counter()
        verdicts = sb.evaluate(far, None, None, 0.1)
        assert time.perf_counter() - t0 < 0.03 + SLACK_S  # containment, not speed: it did not wait for the loop
        assert all(v.fault and "deadline 30 ms exceeded" in v.reason for v in verdicts)
        assert sb.worker_pid != pid and sb.n_restarts == 1
        assert wait_gone(pid)  # the overrunning worker is dead (a zombie until collected)
        end = time.monotonic() + 60.0
        while time.monotonic() < end:  # the replacement comes up with the same program, in the background,
            t0 = time.perf_counter()  # while every frame is answered at once
            verdicts = sb.evaluate(scene, None, None, 0.3)
            assert time.perf_counter() - t0 < 0.03 + SLACK_S
            if not verdicts[0].fault:
                break
            assert all(v.fault and "restarting" in v.reason for v in verdicts), verdicts
            time.sleep(0.01)
        assert [v.ok for v in verdicts] == [True, True] and not any(v.fault for v in verdicts)


def test_worker_crash_is_a_fault_then_replaced(constraints, scene):
    with Sandbox(deadline_s=0.2) as sb:
        sb.load(GOOD, constraints)
        os.kill(sb.worker_pid, signal.SIGKILL)
        time.sleep(0.05)
        verdicts = sb.evaluate(scene, None, None, 0.0)
        assert all(v.fault and "died" in v.reason for v in verdicts), verdicts
        sb.start()  # wait for the replacement
        assert [v.ok for v in sb.evaluate(scene, None, None, 0.0)] == [True, True]


def test_load_errors(sandbox, constraints, scene):
    with pytest.raises(ProgramError, match="ZeroDivisionError"):
        sandbox.load("X = 1 / 0\n" + GOOD, constraints)
    with pytest.raises(SandboxError):  # no program after a failed load
        sandbox.evaluate(scene, None, None, 0.0)
    sandbox.load(GOOD, constraints)
    assert [v.ok for v in sandbox.evaluate(scene, None, None, 0.0)] == [True, True]


def test_module_level_overrun(constraints, scene):
    with Sandbox(load_timeout_s=1.0, deadline_s=5.0) as sb:  # generous: a loaded machine
        with pytest.raises(ProgramError, match="did not finish"):
            sb.load("X = sum(range(10 ** 11))\n" + GOOD, constraints)
        sb.load(GOOD, constraints)
        assert [v.ok for v in sb.evaluate(scene, None, None, 0.0)] == [True, True]


def _stopped_while_loading(sb: Sandbox, constraints, stop_s: float) -> None:
    """Load GOOD into a ready worker that is stopped (SIGSTOP) for ``stop_s`` seconds: a machine too busy
    to run it, its program using no CPU meanwhile."""
    import threading

    w = sb._ready_worker(time.perf_counter() + 60.0, refill=False)  # its ready record is read
    os.kill(w.pid, signal.SIGSTOP)
    timer = threading.Timer(stop_s, os.kill, (w.pid, signal.SIGCONT))
    timer.start()
    try:
        sb._load_into(w, GOOD, constraints, False)
    finally:
        timer.join()


def test_module_level_budget_is_cpu_time_not_a_busy_machines_wall_time(constraints, scene):
    """A worker the machine does not run for 2.5 s (stopped) has used none of its 1 s budget: the load waits
    (up to the wall ceiling) and succeeds; past the ceiling it fails."""
    with Sandbox(load_timeout_s=1.0, deadline_s=5.0) as sb:
        _stopped_while_loading(sb, constraints, 2.5)
        assert [v.ok for v in sb.evaluate(scene, None, None, 0.0)] == [True, True]
    with Sandbox(load_timeout_s=1.0, load_wall_s=1.5, deadline_s=5.0) as sb, \
            pytest.raises(ProgramError, match="did not finish"):
        _stopped_while_loading(sb, constraints, 3.0)


def _resume(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError):  # killed meanwhile (the sandbox gave up on it)
        os.kill(pid, signal.SIGCONT)


def _stopped_at_spawn(sb: Sandbox, stop_s: float) -> None:
    """Make ``sb``'s next worker stopped (SIGSTOP) from its spawn for ``stop_s`` seconds: a machine too busy to
    run it while it boots."""
    import signal
    import threading

    from code_as_monitor.monitor import lifecycle

    make = lifecycle.WorkerProcess

    def stopped(*args, **kw):
        w = make(*args, **kw)
        os.kill(w.pid, signal.SIGSTOP)
        timer = threading.Timer(stop_s, _resume, (w.pid,))
        timer.daemon = True
        timer.start()
        return w

    lifecycle.WorkerProcess = stopped
    try:
        sb._spare_pool()  # the pool's first worker is spawned (stopped) now
        time.sleep(0.2)
    finally:
        lifecycle.WorkerProcess = make


def test_start_budget_is_cpu_time_not_a_busy_machines_wall_time(constraints, scene):
    """A worker the machine does not run for 2.5 s while it boots has used none of its 1 s start budget: the start
    waits (up to the wall ceiling) and succeeds; past the ceiling it fails."""
    sb = Sandbox(start_timeout_s=1.0, deadline_s=5.0)
    try:
        _stopped_at_spawn(sb, 2.5)
        sb.start()
        sb.load(GOOD, constraints)
        assert [v.ok for v in sb.evaluate(scene, None, None, 0.0)] == [True, True]
    finally:
        sb.close()
    sb = Sandbox(start_timeout_s=1.0, start_wall_s=1.5, deadline_s=5.0)
    try:
        _stopped_at_spawn(sb, 3.0)
        with pytest.raises(SandboxError, match="not ready after"):
            sb.start()
    finally:
        sb.close()


def test_evaluate_before_load_and_bad_limits():
    with pytest.raises(SandboxError):
        Sandbox(deadline_s=0.0)
    with Sandbox() as sb, pytest.raises(SandboxError, match="before load"):
        sb.evaluate({}, None, None, 0.0)


def test_reason_is_truncated(sandbox, scene):
    cs = [Constraint("a", "x", "during")]
    sandbox.load("def check_a(E, H, t):\n    return True, 'x' * 100000\n", cs)
    (a,) = sandbox.evaluate(scene, None, None, 0.0)
    assert a.ok and len(a.reason) == 300


def test_frame_shapes_are_checked_and_points_normalised(sandbox, constraints, scene):
    from code_as_monitor.core.errors import ShapeMismatchError

    sandbox.load(GOOD, constraints)
    flat = {0: scene[0][0], 1: scene[1]}  # a (3,) point is accepted as (1, 3)
    assert [v.ok for v in sandbox.evaluate(flat, None, None, 0.0)] == [True, True]
    with pytest.raises(ShapeMismatchError, match="element 1"):
        sandbox.evaluate({0: scene[0], 1: scene[1][:, :2]}, None, None, 0.0)
    H = {i: np.repeat(p[None], 4, axis=0) for i, p in scene.items()}
    with pytest.raises(ShapeMismatchError, match="T=3"):
        sandbox.evaluate(scene, H, np.zeros(3), 0.0)


def test_only_the_worker_executes_generated_code():
    import code_as_monitor.monitor as pkg

    root = os.path.dirname(pkg.__file__)
    for name in sorted(os.listdir(root)):
        if name.endswith(".py") and name != "worker.py":
            with open(os.path.join(root, name)) as f:
                text = f.read()
            assert "exec(" not in text and "eval(" not in text, name


def _status(pid: int) -> dict[str, str]:
    with open(f"/proc/{pid}/status") as f:
        return dict(line.rstrip("\n").split(":\t", 1) for line in f if ":\t" in line)


def test_worker_is_confined_by_the_kernel(sandbox, constraints):
    sandbox.load(GOOD, constraints)
    pid = sandbox.worker_pid
    st = _status(pid)
    assert st["Seccomp"] == "2" and st["NoNewPrivs"] == "1", st  # filter mode, no privilege gain
    assert "seccomp" in sandbox.confinement and "no_new_privs" in sandbox.confinement
    if "network namespace" in sandbox.confinement:  # where the kernel allows them
        assert os.readlink(f"/proc/{pid}/ns/net") != os.readlink("/proc/self/ns/net")
    if "user namespace" in sandbox.confinement:
        assert os.readlink(f"/proc/{pid}/ns/user") != os.readlink("/proc/self/ns/user")


def test_every_load_gets_a_fresh_worker(sandbox, constraints, scene):
    pids = []
    for _ in range(3):
        sandbox.load(GOOD, constraints)
        pids.append(sandbox.worker_pid)
        assert [v.ok for v in sandbox.evaluate(scene, None, None, 0.0)] == [True, True]
    assert len(set(pids)) == 3
    assert all(wait_gone(p) for p in pids[:-1])
