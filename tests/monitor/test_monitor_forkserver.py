"""The sandbox's fork server: workers forked from a clean interpreter, their exits reported and their pids
held until read, a server that ends replaced, and the exec path still there."""

from __future__ import annotations

import os
import signal
import subprocess
import time

import pytest

from code_as_monitor.monitor import forkserver, process
from code_as_monitor.monitor.forkserver import ForkServer, server_cpu_seconds, shared_server
from code_as_monitor.monitor.process import _SRC_ROOT, _WORKER_ENV, WorkerProcess


def _ppid(pid: int) -> int:
    with open(f"/proc/{pid}/stat", "rb") as f:
        return int(f.read().rsplit(b")", 1)[1].split()[1])


def _children(pid: int) -> list[tuple[int, str]]:
    """(pid, state) of every process whose parent is ``pid``."""
    out = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat", "rb") as f:
                    fields = f.read().rsplit(b")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                out.append((int(name), fields[0].decode()))
    return out


def _ready(w: WorkerProcess) -> None:
    w.recv(time.perf_counter() + 20.0)  # the ready record


def test_a_worker_is_forked_by_the_server_not_by_the_control_process():
    w = WorkerProcess(256, 60, confine=True)
    try:
        _ready(w)
        server = shared_server(_WORKER_ENV, _SRC_ROOT)
        assert isinstance(w.proc, forkserver.ForkedProcess)
        assert _ppid(w.pid) == server.pid != os.getpid()
        with open(f"/proc/{server.pid}/cmdline", "rb") as f:  # a clean interpreter running the server only
            assert b"forkserver import serve" in f.read()
    finally:
        w.kill()
        assert w.reap(10.0)


def test_a_killed_worker_reports_its_signal_and_is_released():
    w = WorkerProcess(256, 60, confine=True)
    _ready(w)
    server = shared_server(_WORKER_ENV, _SRC_ROOT)
    w.kill()
    assert w.proc.wait(timeout=10) == -signal.SIGKILL
    assert "killed by SIGKILL" in w.how_it_ended()
    end = time.monotonic() + 10
    while any(pid == w.pid for pid, _ in _children(server.pid)) and time.monotonic() < end:
        time.sleep(0.02)  # the release reaches the server, which collects the zombie
    assert all(pid != w.pid for pid, _ in _children(server.pid))


def test_an_exited_worker_is_held_as_a_zombie_until_its_status_is_read():
    w = WorkerProcess(256, 60, confine=True)
    _ready(w)
    server = shared_server(_WORKER_ENV, _SRC_ROOT)
    os.kill(w.pid, signal.SIGTERM)  # not through the handle: the control side has not read the exit yet
    end = time.monotonic() + 10
    while dict(_children(server.pid)).get(w.pid) != "Z" and time.monotonic() < end:
        time.sleep(0.02)
    assert dict(_children(server.pid)).get(w.pid) == "Z"  # the pid stays taken: a kill cannot hit another
    assert w.proc.wait(timeout=10) == -signal.SIGTERM


def test_many_workers_leave_no_zombies():
    workers = [WorkerProcess(256, 60, confine=True) for _ in range(6)]
    for w in workers:
        _ready(w)
        w.kill()
    for w in workers:
        assert w.reap(10.0)
    server = shared_server(_WORKER_ENV, _SRC_ROOT)
    end = time.monotonic() + 10
    while _children(server.pid) and time.monotonic() < end:
        time.sleep(0.02)
    assert _children(server.pid) == []


def test_a_server_that_ended_is_replaced_and_its_workers_count_as_killed():
    w = WorkerProcess(256, 60, confine=True)
    _ready(w)
    old = shared_server(_WORKER_ENV, _SRC_ROOT)
    os.kill(old.pid, signal.SIGKILL)
    assert w.proc.wait(timeout=10) == -signal.SIGKILL  # it died with its server (death signal)
    with pytest.raises(OSError, match="fork server has ended"):
        old.spawn(0, 2, 256, 60, True)
    w2 = WorkerProcess(256, 60, confine=True)
    try:
        _ready(w2)
        assert shared_server(_WORKER_ENV, _SRC_ROOT).pid != old.pid
    finally:
        w2.kill()
        w2.reap(10.0)


def test_the_server_dies_with_the_thread_that_started_it(tmp_path):
    code = ("import sys, time; sys.path.insert(0, sys.argv[1]); "
            "from code_as_monitor.monitor.forkserver import ForkServer; "
            "from code_as_monitor.monitor.process import _WORKER_ENV, _SRC_ROOT; "
            "s = ForkServer(_WORKER_ENV, _SRC_ROOT); print(s.pid, flush=True); time.sleep(60)")
    parent = subprocess.Popen([os.sys.executable, "-c", code, _SRC_ROOT], stdout=subprocess.PIPE, text=True)
    server_pid = int(parent.stdout.readline())
    parent.kill()
    parent.wait(10)
    end = time.monotonic() + 10
    while os.path.exists(f"/proc/{server_pid}") and time.monotonic() < end:
        with open(f"/proc/{server_pid}/stat", "rb") as f:
            if f.read().rsplit(b")", 1)[1].split()[0] == b"Z":
                break
        time.sleep(0.02)
    gone = not os.path.exists(f"/proc/{server_pid}")
    if not gone:
        with open(f"/proc/{server_pid}/stat", "rb") as f:
            gone = f.read().rsplit(b")", 1)[1].split()[0] == b"Z"
    assert gone


def test_the_server_counts_the_cpu_of_the_workers_it_collected(constraints, scene):
    from code_as_monitor.monitor.sandbox import Sandbox

    spin = ("def check_a(E, H, t):\n    for i in range(3_000_000):\n        pass\n    return True, 'x'\n\n\n"
            "def check_b(E, H, t):\n    return True, 'fine'\n")
    before = server_cpu_seconds()
    with Sandbox(deadline_s=30.0) as sb:
        sb.load(spin, constraints)
        for k in range(3):
            a, _ = sb.evaluate(scene, None, None, 1.0 + k)
            assert a.ok and not a.fault, a.reason
        used = sb._active.cpu_seconds()  # what the worker ran, by its own /proc entry
    assert used >= 0.05
    end = time.monotonic() + 10
    while server_cpu_seconds() - before < used - 0.02 and time.monotonic() < end:
        time.sleep(0.05)  # counted once the release reaches the server and it collects the worker
    assert server_cpu_seconds() - before >= used - 0.02  # one clock tick of slack (10 ms) per reading


def test_the_exec_path_starts_a_child_of_the_control_process(monkeypatch):
    monkeypatch.setattr(process, "SPAWN", "exec")
    w = WorkerProcess(256, 60, confine=True)
    try:
        _ready(w)
        assert isinstance(w.proc, subprocess.Popen)
        assert _ppid(w.pid) == os.getpid()
    finally:
        w.kill()
        w.reap(10.0)


def test_an_unknown_spawn_mode_is_an_oserror_naming_it(monkeypatch):
    monkeypatch.setattr(process, "SPAWN", "vfork")
    with pytest.raises(OSError, match=r"CAM_SANDBOX_SPAWN.*'vfork'"):
        WorkerProcess(256, 60, confine=True)


def test_a_server_ignores_a_malformed_request():
    s = ForkServer(_WORKER_ENV, _SRC_ROOT)
    try:
        s.sock.send(b"garbage")
        w = None
        a, b = __import__("socket").socketpair()
        with open(os.devnull, "wb") as err:
            w = s.spawn(b.fileno(), err.fileno(), 256, 60, True)
        b.close()
        assert w.pid > 0 and _ppid(w.pid) == s.pid
        w.kill()
        assert w.wait(10) == -signal.SIGKILL
        a.close()
    finally:
        s.close()
