"""Benchmark: how far past its deadline ``Sandbox.evaluate`` returns when a program never answers.

Each trial loads a program whose first check loops forever, evaluates one frame with the real-time
deadline (20 ms) and times the call: it must return fault verdicts, and the overshoot is the time past
the deadline. Two cases: right after the load, while the next spare is starting (its imports and
warm-up compete for the CPU), and settled, once that spare has said ready. The reference, measured in
the same run and interleaved with the trials: a plain 20 ms ``poll`` in this process while a child
process spins on a CPU (what the stalled worker does), i.e. the kernel's wake-up latency under the
machine's load, which no code in the control process can beat. The whole measurement is repeated
``--repeats`` times; figures are medians over the repeats of per-repeat medians (the maximum is the
maximum over everything).

Run: ``.venv/bin/python benchmarks/sandbox_deadline.py [--frames N] [--repeats N]``; the last lines read
``name: value unit``.
"""

from __future__ import annotations

import argparse
import os
import select
import statistics
import subprocess
import sys
import time

import numpy as np

from code_as_monitor.core.constraints import Constraint, Phase
from code_as_monitor.monitor.sandbox import Sandbox

DEADLINE_S = 0.020
STALL = ("def check_a(E, H, t):\n    for i in range(10 ** 12):\n        pass\n    return True, 'x'\n\n\n"
         "def check_b(E, H, t):\n    return True, 'fine'\n")
CONSTRAINTS = [Constraint("a", "never answers", Phase.DURING), Constraint("b", "answers", Phase.UPON)]
E = {0: np.array([[0.0, 0.0, 0.22]]), 1: np.array([[0.0, 0.0, 0.2]] * 4)}


def poll_overshoot_ms() -> float:
    """ms past 20 ms of a plain poll on a socket that never becomes readable, with a child spinning."""
    spinner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.005)
        r, w = os.pipe()
        p = select.poll()
        p.register(r, select.POLLIN)
        t0 = time.perf_counter()
        p.poll(DEADLINE_S * 1e3)
        dt = time.perf_counter() - t0
        os.close(r)
        os.close(w)
    finally:
        spinner.kill()
        spinner.wait()
    return (dt - DEADLINE_S) * 1e3


def stalled_frame_ms(sb: Sandbox, settled: bool) -> float:
    """ms past the deadline of one frame of the stalling program (loaded just before)."""
    sb.load(STALL, CONSTRAINTS)
    if settled:
        sb.start()  # wait until the next spare has said ready
    t0 = time.perf_counter()
    verdicts = sb.evaluate(E, None, None, 0.0)
    dt = time.perf_counter() - t0
    if not all(v.fault and "deadline" in v.reason for v in verdicts):
        raise SystemExit(f"expected deadline faults, got {verdicts}")
    return (dt - DEADLINE_S) * 1e3


def one_repeat(sb: Sandbox, frames: int) -> tuple[list[float], list[float], list[float]]:
    """(overshoots right after a load, overshoots settled, reference poll overshoots), interleaved."""
    fresh, settled, ref = [], [], []
    for _ in range(frames):
        fresh.append(stalled_frame_ms(sb, settled=False))
        settled.append(stalled_frame_ms(sb, settled=True))
        ref.append(poll_overshoot_ms())
    return fresh, settled, ref


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20, help="stalled frames per repeat (>= 5)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats (>= 3)")
    args = parser.parse_args()
    frames, n_rep = max(5, args.frames), max(3, args.repeats)
    runs = []
    with Sandbox(deadline_s=DEADLINE_S) as sb:
        for _ in range(n_rep):
            runs.append(one_repeat(sb, frames))
    med = statistics.median

    def figures(k: int) -> tuple[float, float, list[float]]:
        per = [med(r[k]) for r in runs]
        return med(per), max(max(r[k]) for r in runs), per

    fresh, fresh_max, fresh_per = figures(0)
    settled, settled_max, settled_per = figures(1)
    ref, ref_max, ref_per = figures(2)
    ratio = med(med(r[1]) / max(med(r[2]), 1e-3) for r in runs)
    print(f"{frames} stalled frames per case x {n_rep} repeats, deadline {DEADLINE_S * 1e3:.0f} ms; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"evaluate past the deadline, right after a load: median {fresh:.2f} ms (repeats "
          f"{[round(x, 2) for x in fresh_per]}), max {fresh_max:.2f} ms")
    print(f"evaluate past the deadline, spare settled:      median {settled:.2f} ms (repeats "
          f"{[round(x, 2) for x in settled_per]}), max {settled_max:.2f} ms")
    print(f"plain 20 ms poll past its timeout (reference):  median {ref:.2f} ms (repeats "
          f"{[round(x, 2) for x in ref_per]}), max {ref_max:.2f} ms")
    print(f"deadline_overshoot_after_load_median: {fresh:.2f} ms")
    print(f"deadline_overshoot_median: {settled:.2f} ms")
    print(f"deadline_overshoot_max: {max(fresh_max, settled_max):.2f} ms")
    print(f"poll_overshoot_median: {ref:.2f} ms")
    print(f"overshoot_vs_poll_ratio: {ratio:.2f} x")

if __name__ == "__main__":
    main()
