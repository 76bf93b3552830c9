"""The ray executor gives the same records as the local one (skipped only without the `ray` extra)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time

import pytest

from code_as_monitor.bench.executors import ExecutorConfig, LocalExecutorConfig, RayExecutorConfig
from code_as_monitor.bench.protocol import BenchSpec
from code_as_monitor.bench.runner import read_results, record_key, run_bench
from code_as_monitor.core.errors import ConfigError

pytest.importorskip("pybullet")

VOLATILE = ("wall_time_s", "cpu_time_s", "finished_at", "video", "reproduce")  # reproduce names the results file


def _records(path) -> dict:
    return {record_key(r): {k: v for k, v in r.items() if k not in VOLATILE}
            for r in read_results(path) if r["kind"] == "episode"}


def test_default_workers_are_the_usable_cores():
    want = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert LocalExecutorConfig().n_workers() == want and RayExecutorConfig().n_workers() == want
    assert LocalExecutorConfig(workers=3).n_workers() == 3


def test_executor_registry():
    assert set(ExecutorConfig.choices()) >= {"local", "ray"}
    assert isinstance(ExecutorConfig.from_name("ray", address="auto"), RayExecutorConfig)
    with pytest.raises(ConfigError):
        ExecutorConfig.from_name("local", workers=-1)


def test_ray_matches_local_on_a_tiny_sweep(tmp_path):
    pytest.importorskip("ray")
    spec = BenchSpec(methods=["open-loop", "doremi"], conditions=["stack-p0.3"], seeds=1, episodes=1)
    run_bench(spec, tmp_path / "local.jsonl", LocalExecutorConfig(workers=2))  # the process pool
    run_bench(spec, tmp_path / "ray.jsonl", RayExecutorConfig(workers=2))  # a local Ray instance
    local, ray = _records(tmp_path / "local.jsonl"), _records(tmp_path / "ray.jsonl")
    assert len(local) == 2 and local == ray


# ----- no process outlives a killed `cam bench` -------------------------------------------------------

def _proc_table() -> dict[int, tuple[int, str]]:
    """pid -> (ppid, start time) of every live (non-zombie) process."""
    out = {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # after "pid (comm) "
        if fields[0] in ("Z", "X"):
            continue
        out[int(d)] = (int(fields[1]), fields[19])
    return out


def _descendants(root: int) -> dict[int, str]:
    """pid -> start time of every live descendant of ``root``."""
    table = _proc_table()
    found: dict[int, str] = {}
    frontier = [root]
    while frontier:
        parent = frontier.pop()
        for pid, (ppid, start) in table.items():
            if ppid == parent and pid not in found:
                found[pid] = start
                frontier.append(pid)
    return found


def _alive(procs: dict[int, str]) -> list[int]:
    table = _proc_table()
    return [pid for pid, start in procs.items() if pid in table and table[pid][1] == start]


def _finished(results) -> int:
    return results.read_text().count('"kind":"episode"') if results.exists() else 0


def _kill_bench(tmp_path, sig: int, executor: list[str], want_children: int) -> list[int]:
    """Start a tiny `cam bench`, wait for its workers, send ``sig`` to the parent alone and return the pids
    of its former descendants still alive 30 s later (killing them, so a failure leaks nothing)."""
    results = tmp_path / "r.jsonl"
    args = [sys.executable, "-m", "code_as_monitor.cli.main", "bench", "--methods", "open-loop", "--conditions",
            "stack-p0", "--seeds", "1", "--episodes", "12", "--no-videos", "--results", str(results), *executor]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    kids: dict[int, str] = {}
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            kids.update(_descendants(proc.pid))
            if len(_alive(kids)) >= want_children and _finished(results) >= 1:  # workers mid-sweep
                break
            time.sleep(0.2)
        assert proc.poll() is None and _finished(results) >= 1, "the bench ended before it was killed"
        kids.update(_descendants(proc.pid))
        os.kill(proc.pid, sig)
        proc.wait(60)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and _alive(kids):
            time.sleep(0.2)
        return _alive(kids)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        for pid in _alive(kids):
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT], ids=["KILL", "TERM", "INT"])
def test_pool_workers_and_resource_tracker_die_with_cam_bench(tmp_path, sig):
    # 2 pool workers + the multiprocessing resource tracker
    left = _kill_bench(tmp_path, sig, ["--workers", "2"], want_children=3)
    assert left == [], f"still alive after the parent died: {left}"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT], ids=["KILL", "TERM", "INT"])
def test_ray_processes_die_with_cam_bench(tmp_path, sig):
    pytest.importorskip("ray")
    left = _kill_bench(tmp_path, sig, ["--executor", "ray", "--workers", "2"], want_children=4)
    assert left == [], f"still alive after the parent died: {left}"
