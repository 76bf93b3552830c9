"""Benchmark: what one sandbox worker costs to start, forked from the fork server against a new interpreter.

A monitored stacking episode loads 10-20 programs, each into a fresh worker, so the start is paid per program.
Measured in one process, the two ways interleaved (``CAM_SANDBOX_SPAWN``'s ``fork`` and ``exec``, set through
``monitor.process.SPAWN``) so that both see the same machine load: for each round, ``--workers`` workers are
started, waited for until ready (imported, warmed up, confined), killed and collected. Per worker:

- CPU seconds (user + system): for ``exec`` this process's collected children; for ``fork`` the fork server's
  collected children (``/proc/<server>/stat``'s cutime + cstime), read once the server has reaped them;
- wall milliseconds from the spawn request to the ready record.

Each figure is the median over ``--rounds`` rounds of the per-round mean; the ratio is exec over fork in the
same round (median). Run: ``.venv/bin/python benchmarks/worker_start.py [--rounds 5] [--workers 8]``; the last
lines read ``name: value unit``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from code_as_monitor.monitor import forkserver, process
from code_as_monitor.monitor.process import _SRC_ROOT, _WORKER_ENV, WorkerProcess


def _server_children_cpu() -> float:
    s = forkserver.shared_server(_WORKER_ENV, _SRC_ROOT)
    return forkserver.proc_cpu_seconds(s.pid, collected=True) - forkserver.proc_cpu_seconds(s.pid)


def _own_children_cpu() -> float:
    t = os.times()
    return t.children_user + t.children_system


def one_round(mode: str, n: int) -> tuple[float, float]:
    """(CPU seconds per worker, wall ms to ready per worker) for ``n`` workers started the ``mode`` way."""
    process.SPAWN = mode
    cpu = _server_children_cpu if mode == "fork" else _own_children_cpu
    c0 = cpu()
    walls = []
    for _ in range(n):
        t0 = time.perf_counter()
        w = WorkerProcess(512, 600, confine=True)
        w.recv(time.perf_counter() + 60.0)  # the ready record
        walls.append((time.perf_counter() - t0) * 1e3)
        w.kill()
        w.reap(10.0)
    time.sleep(0.2)  # the fork server collects its released zombies
    return (cpu() - c0) / n, statistics.mean(walls)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--workers", type=int, default=8, help="workers started per round and way")
    args = ap.parse_args()
    one_round("fork", 1)  # the server itself starts once (not counted)
    res: dict[str, list[tuple[float, float]]] = {"fork": [], "exec": []}
    for r in range(args.rounds):
        for mode in ("fork", "exec") if r % 2 == 0 else ("exec", "fork"):
            res[mode].append(one_round(mode, args.workers))
        print(f"round {r}: fork {res['fork'][-1][0] * 1e3:.1f} ms CPU, {res['fork'][-1][1]:.1f} ms wall; "
              f"exec {res['exec'][-1][0] * 1e3:.1f} ms CPU, {res['exec'][-1][1]:.1f} ms wall")
    ratio = statistics.median(e[0] / max(f[0], 1e-6) for f, e in zip(res["fork"], res["exec"], strict=True))
    for mode in ("fork", "exec"):
        print(f"worker_start_cpu_{mode}: {statistics.median(c for c, _ in res[mode]) * 1e3:.1f} ms")
        print(f"worker_start_wall_{mode}: {statistics.median(w for _, w in res[mode]):.1f} ms")
    print(f"worker_start_cpu_ratio_exec_vs_fork: {ratio:.1f} x")


if __name__ == "__main__":
    main()
