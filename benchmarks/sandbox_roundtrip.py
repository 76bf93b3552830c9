"""Benchmark: one sandbox round trip (all checks of one frame), a program load, and what confinement costs.

A realistic monitor program (4 checks: 2 during, 2 upon) on 6 elements with a T=30 history. Measured in
the same run:

- the round trip in a confined worker (seccomp, no_new_privs, namespaces), and the transport alone
  (4 checks returning constants);
- the same in an unconfined worker (``Sandbox(confine=False, allow_unconfined=True)``): the reference
  for the confinement's cost, as ratios;
- the same checks in this process through a trusted, hand-written function (no exec of any string,
  ever, in this process);
- ``Sandbox.load`` of the program into a fresh worker: a spare that was started, warmed up and confined
  in the background (a fresh worker per load), plus the spare's own start-up time for reference.

Targets: round trip <= 0.15 ms, program load <= 50 ms. Run:
``.venv/bin/python benchmarks/sandbox_roundtrip.py [--calls N] [--loads N]``; the last lines read
``program_load_median: ... ms`` and ``sandbox_roundtrip_median: ... ms``.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np

from code_as_monitor.core.constraints import Constraint, Phase
from code_as_monitor.geometry.helpers import (
    angle_to_vertical,
    displacement,
    distance,
    normal,
    point_above_surface,
)
from code_as_monitor.monitor.sandbox import Sandbox

PROGRAM = '''
def check_attached(E, H, t):
    d = distance(E[0], E[1])
    if d > 0.03:
        return False, f"block is {d:.3f} m from the suction cup", 0.03 - d
    return True, "block attached", 0.03 - d


def check_level(E, H, t):
    tilt = angle_to_vertical(normal(E[1]))
    ok = tilt < math.radians(15)
    return ok, f"block top tilted {math.degrees(tilt):.1f} deg", math.radians(15) - tilt


def check_on_target(E, H, t):
    above = point_above_surface(E[1], E[2], 0.01)
    return above, "block above the target" if above else "block not above the target"


def check_others_still(E, H, t):
    moved = max(displacement(H[i]) for i in (3, 4, 5))
    return moved < 0.02, f"other blocks moved {moved:.3f} m", 0.02 - moved
'''

EMPTY = '''
def check_attached(E, H, t):
    return True, "x"


def check_level(E, H, t):
    return True, "x"


def check_on_target(E, H, t):
    return True, "x"


def check_others_still(E, H, t):
    return True, "x"
'''

CONSTRAINTS = [
    Constraint("attached", "the block stays on the suction cup", Phase.DURING),
    Constraint("level", "the block stays level", Phase.DURING),
    Constraint("on_target", "the block ends above the target", Phase.UPON),
    Constraint("others_still", "the other blocks do not move", Phase.UPON),
]


def reference(E: dict, H: dict, t: float) -> list[tuple]:
    """The same checks as PROGRAM, hand-written and trusted, evaluated in this process."""
    d = distance(E[0], E[1])
    a = (False, f"block is {d:.3f} m from the suction cup", 0.03 - d) if d > 0.03 else \
        (True, "block attached", 0.03 - d)
    tilt = angle_to_vertical(normal(E[1]))
    b = (tilt < math.radians(15), f"block top tilted {math.degrees(tilt):.1f} deg", math.radians(15) - tilt)
    above = point_above_surface(E[1], E[2], 0.01)
    c = (above, "block above the target" if above else "block not above the target")
    moved = max(displacement(H[i]) for i in (3, 4, 5))
    e = (moved < 0.02, f"other blocks moved {moved:.3f} m", 0.02 - moved)
    return [a, b, c, e]


def scene(rng: np.random.Generator, T: int = 30) -> tuple[dict, dict, np.ndarray]:
    square = np.array([[-0.02, -0.02, 0.0], [0.02, -0.02, 0.0], [0.02, 0.02, 0.0], [-0.02, 0.02, 0.0]])
    E = {
        0: np.array([[0.3, 0.0, 0.25]]),  # suction cup tip (point)
        1: square + np.array([0.3, 0.0, 0.23]),  # carried block top (surface)
        2: 2.5 * square + np.array([0.5, 0.2, 0.05]),  # target block top (surface)
        3: np.array([[0.1, 0.3, 0.0], [0.15, 0.3, 0.0]]),  # other blocks (lines)
        4: np.array([[0.1, -0.3, 0.0], [0.15, -0.3, 0.0]]),
        5: np.array([[0.6, -0.2, 0.0], [0.65, -0.2, 0.0]]),
    }
    H = {i: p[None] + rng.normal(0.0, 0.001, (T, *p.shape)) for i, p in E.items()}
    return E, H, np.linspace(0.0, (T - 1) / 30.0, T)


def median_ms(fn, n: int) -> tuple[float, float]:
    times = np.empty(n)
    for k in range(n):
        t0 = time.perf_counter()
        fn()
        times[k] = time.perf_counter() - t0
    return float(np.median(times) * 1e3), float(np.percentile(times, 99) * 1e3)


def roundtrips(sb: Sandbox, E: dict, H: dict, Ht: np.ndarray, n: int) -> tuple[float, float, float, float, int]:
    """(transport median, transport p99, realistic median, realistic p99, faults) on one sandbox."""
    t = float(Ht[-1])
    sb.load(EMPTY, CONSTRAINTS)
    for _ in range(500):
        sb.evaluate(E, H, Ht, t)
    empty_med, empty_p99 = median_ms(lambda: sb.evaluate(E, H, Ht, t), n)
    sb.load(PROGRAM, CONSTRAINTS)
    verdicts = sb.evaluate(E, H, Ht, t)
    ref = reference(E, H, t)
    assert [v.ok for v in verdicts] == [bool(r[0]) for r in ref], (verdicts, ref)
    assert not any(v.fault for v in verdicts), verdicts
    for _ in range(500):
        sb.evaluate(E, H, Ht, t)
    med, p99 = median_ms(lambda: sb.evaluate(E, H, Ht, t), n)
    faults = sum(v.fault for _ in range(200) for v in sb.evaluate(E, H, Ht, t))
    return empty_med, empty_p99, med, p99, faults


def loads(sb: Sandbox, n: int) -> tuple[list[float], list[float], list[float]]:
    """Per load: ms of ``load`` with a started spare ready (it is fresh: never ran a program), ms from a
    worker's spawn to its ready record (imports, warm-up, limits, confinement), ms of the confinement."""
    load_ms, ready_ms, confine_ms = [], [], []
    for _ in range(n):
        sb.start()  # wait until a spare has said ready, as between subgoals
        t0 = time.perf_counter()
        sb.load(PROGRAM, CONSTRAINTS)
        load_ms.append((time.perf_counter() - t0) * 1e3)
        w = sb._active
        ready_ms.append(w.ready_s * 1e3)
        confine_ms.append(w.confine_ms)
    return load_ms, ready_ms, confine_ms


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=5000, help="timed calls per measurement (>= 1000)")
    parser.add_argument("--loads", type=int, default=20, help="timed program loads per sandbox (>= 5)")
    args = parser.parse_args()
    n, n_loads = max(1000, args.calls), max(5, args.loads)
    E, H, Ht = scene(np.random.default_rng(0))
    t = float(Ht[-1])
    with Sandbox() as sb:
        confinement = sb.confinement
        empty_med, empty_p99, sb_med, sb_p99, faults = roundtrips(sb, E, H, Ht, n)
        load_ms, ready_ms, confine_ms = loads(sb, n_loads)
    with Sandbox(confine=False, allow_unconfined=True) as ub:  # the reference: same worker, no confinement
        _, _, un_med, un_p99, _ = roundtrips(ub, E, H, Ht, n)
        un_load_ms, un_ready_ms, _ = loads(ub, n_loads)
    for _ in range(500):
        reference(E, H, t)
    ref_med, ref_p99 = median_ms(lambda: reference(E, H, t), n)
    med = statistics.median
    try:
        load_avg = os.getloadavg()[0]
    except OSError:
        load_avg = math.nan

    print(f"program: {len(CONSTRAINTS)} checks, {len(E)} elements, history T={len(Ht)}; {n} timed calls each, "
          f"{n_loads} loads; machine load average {load_avg:.1f} on {os.cpu_count()} cores")
    print(f"confined worker: {confinement}")
    print(f"transport only (constant checks): median {empty_med:.3f} ms, p99 {empty_p99:.3f} ms")
    print(f"sandbox evaluate (realistic):     median {sb_med:.3f} ms, p99 {sb_p99:.3f} ms, faults {faults}")
    print(f"unconfined worker (reference):    median {un_med:.3f} ms, p99 {un_p99:.3f} ms")
    print(f"in-process reference (trusted):   median {ref_med:.3f} ms, p99 {ref_p99:.3f} ms")
    print(f"program load (fresh spare):       median {med(load_ms):.2f} ms (unconfined {med(un_load_ms):.2f} ms)")
    print(f"worker start, spawn to ready:     median {med(ready_ms):.0f} ms (unconfined {med(un_ready_ms):.0f} ms),"
          " in the background")
    print(f"confinement install in a worker:  median {med(confine_ms):.2f} ms")
    print(f"sandbox_overhead_median: {sb_med - ref_med:.3f} ms")
    print(f"sandbox_vs_inprocess_ratio: {sb_med / ref_med:.2f}")
    print(f"sandbox_transport_median: {empty_med:.3f} ms")
    print(f"confinement_roundtrip_ratio: {sb_med / un_med:.2f}")
    print(f"confinement_load_ratio: {med(load_ms) / med(un_load_ms):.2f}")
    print(f"confinement_install_median: {med(confine_ms):.2f} ms")
    print(f"worker_start_median: {med(ready_ms):.0f} ms")
    print(f"program_load_median: {med(load_ms):.2f} ms")
    print(f"sandbox_roundtrip_median: {sb_med:.3f} ms")


if __name__ == "__main__":
    main()
