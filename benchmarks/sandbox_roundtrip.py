"""Benchmark: one sandbox round trip (all checks of one frame), a program load, and what confinement costs.

A realistic monitor program (4 checks: 2 during, 2 upon) on 6 elements with a T=30 history. Measured in
the same run:

- the round trip in a confined worker (seccomp, no_new_privs, namespaces), and the transport alone
  (4 checks returning constants);
- the same in an unconfined worker (``Sandbox(confine=False, allow_unconfined=True)``): the reference
  for the confinement's cost, as ratios;
- the same checks in this process through a trusted, hand-written function (no exec of any string,
  ever, in this process), timed in a tight loop and timed between sandbox calls (its caches then as
  cold as the worker's: on a loaded 2-core machine that alone doubled its time);
- ``Sandbox.load`` of the program into a fresh worker: a spare that was started, warmed up and confined
  in the background (a fresh worker per load), plus the spare's own start-up time for reference.

Every measurement is repeated ``--repeats`` times (confined and unconfined sandboxes interleaved, so
that both see the same machine load); each figure is the median over the repeats of the per-repeat
medians, each ratio the median of the per-repeat ratios, with the spread (min-max over the repeats)
printed beside it. Timed calls get a generous deadline (1 s) so that a slow call counts as slow rather
than as a fast "restarting" fault; calls over the real-time 20 ms budget are counted.

Targets: round trip <= 0.15 ms, program load <= 50 ms. Run:
``.venv/bin/python benchmarks/sandbox_roundtrip.py [--calls N] [--loads N] [--repeats N]``; the last lines
read ``name: value unit`` (``program_load_median: ... ms``, ``sandbox_roundtrip_median: ... ms`` ...).
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


TIMED_DEADLINE_S = 1.0
"""Deadline of the timed calls: generous, so that a call slowed by the machine is timed, not replaced."""
REAL_TIME_S = 0.020
"""The sandbox's real-time budget per frame; timed calls over it are counted."""


def timed_ms(fn, n: int) -> np.ndarray:
    """Milliseconds of ``n`` calls of ``fn``."""
    times = np.empty(n)
    for k in range(n):
        t0 = time.perf_counter()
        fn()
        times[k] = time.perf_counter() - t0
    return times * 1e3


def roundtrips(sb: Sandbox, E: dict, H: dict, Ht: np.ndarray, n: int) -> dict[str, float]:
    """Transport (constant checks) and realistic round trips on one sandbox: medians, p99s, faults, overruns."""
    t = float(Ht[-1])

    def call() -> list:
        return sb.evaluate(E, H, Ht, t, deadline_s=TIMED_DEADLINE_S)

    sb.load(EMPTY, CONSTRAINTS)
    for _ in range(500):
        call()
    empty = timed_ms(call, n)
    sb.load(PROGRAM, CONSTRAINTS)
    verdicts = call()
    ref = reference(E, H, t)
    if [v.ok for v in verdicts] != [bool(r[0]) for r in ref] or any(v.fault for v in verdicts):
        raise SystemExit(f"the sandboxed program disagrees with the reference: {verdicts} vs {ref}")
    for _ in range(500):
        call()
    real = timed_ms(call, n)
    faults = sum(v.fault for _ in range(200) for v in call())
    inter = np.empty(n)  # the trusted reference between sandbox calls: caches as cold as the worker's
    for k in range(n):
        call()
        t0 = time.perf_counter()
        reference(E, H, t)
        inter[k] = time.perf_counter() - t0
    return {"empty_med": float(np.median(empty)), "empty_p99": float(np.percentile(empty, 99)),
            "med": float(np.median(real)), "p99": float(np.percentile(real, 99)), "faults": faults,
            "inter_med": float(np.median(inter) * 1e3),
            "over": int((real > REAL_TIME_S * 1e3).sum() + (empty > REAL_TIME_S * 1e3).sum())}


def loads(sb: Sandbox, n: int) -> dict[str, float]:
    """Medians over ``n`` loads: ms of ``load`` with a started spare ready (it is fresh: never ran a program),
    ms from a worker's spawn to its ready record (imports, warm-up, limits, confinement), ms of the
    confinement itself."""
    load_ms, ready_ms, confine_ms = [], [], []
    for _ in range(n):
        sb.start()  # wait until a spare has said ready, as between subgoals
        t0 = time.perf_counter()
        sb.load(PROGRAM, CONSTRAINTS)
        load_ms.append((time.perf_counter() - t0) * 1e3)
        w = sb._active
        ready_ms.append(w.ready_s * 1e3)
        confine_ms.append(w.confine_ms)
    med = statistics.median
    return {"load": med(load_ms), "ready": med(ready_ms), "confine": med(confine_ms)}


def one_repeat(E: dict, H: dict, Ht: np.ndarray, n: int, n_loads: int) -> dict[str, float]:
    """Confined, then unconfined (the reference for the confinement's cost), then the in-process reference."""
    out: dict[str, float] = {}
    with Sandbox() as sb:
        out["confinement"] = sb.confinement  # type: ignore[assignment]
        out.update(roundtrips(sb, E, H, Ht, n))
        out.update(loads(sb, n_loads))
    with Sandbox(confine=False, allow_unconfined=True) as ub:  # same worker, no confinement
        out.update({f"un_{k}": v for k, v in roundtrips(ub, E, H, Ht, n).items()})
        out.update({f"un_{k}": v for k, v in loads(ub, n_loads).items()})
    t = float(Ht[-1])
    for _ in range(500):
        reference(E, H, t)
    ref = timed_ms(lambda: reference(E, H, t), n)
    out["ref_med"], out["ref_p99"] = float(np.median(ref)), float(np.percentile(ref, 99))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=5000, help="timed calls per measurement (>= 1000)")
    parser.add_argument("--loads", type=int, default=20, help="timed program loads per sandbox (>= 5)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats of the whole measurement (>= 3)")
    args = parser.parse_args()
    n, n_loads, n_rep = max(1000, args.calls), max(5, args.loads), max(3, args.repeats)
    E, H, Ht = scene(np.random.default_rng(0))
    runs = [one_repeat(E, H, Ht, n, n_loads) for _ in range(n_rep)]
    try:
        load_avg = os.getloadavg()[0]
    except OSError:
        load_avg = math.nan

    def fig(key: str) -> tuple[float, float, float]:
        vals = [r[key] for r in runs]
        return statistics.median(vals), min(vals), max(vals)

    def ratio(num: str, den: str) -> tuple[float, float, float]:
        vals = [r[num] / r[den] for r in runs]
        return statistics.median(vals), min(vals), max(vals)

    def show(label: str, key: str, unit: str = "ms", digits: int = 3) -> None:
        m, lo, hi = fig(key)
        print(f"{label:<40} median {m:.{digits}f} {unit} (repeats {lo:.{digits}f}-{hi:.{digits}f})")

    print(f"program: {len(CONSTRAINTS)} checks, {len(E)} elements, history T={len(Ht)}; {n} timed calls and "
          f"{n_loads} loads per sandbox, {n_rep} repeats; load average {load_avg:.1f} on {os.cpu_count()} cores")
    print(f"confined worker: {runs[0]['confinement']}")
    show("transport only (constant checks):", "empty_med")
    show("sandbox evaluate (realistic):", "med")
    show("  its p99:", "p99")
    show("unconfined worker (reference):", "un_med")
    show("in-process reference (trusted):", "ref_med")
    show("  the same between sandbox calls:", "inter_med")
    show("program load (fresh spare):", "load", digits=2)
    show("program load, unconfined:", "un_load", digits=2)
    show("worker start, spawn to ready (background):", "ready", digits=0)
    show("  unconfined:", "un_ready", digits=0)
    show("confinement install in a worker:", "confine", digits=2)
    print(f"faults in 200 checked frames per repeat: {[r['faults'] for r in runs]}; timed calls over "
          f"{REAL_TIME_S * 1e3:.0f} ms (confined): {[r['over'] for r in runs]}")
    rt_ratio, rt_lo, rt_hi = ratio("med", "un_med")
    ld_ratio, ld_lo, ld_hi = ratio("load", "un_load")
    print(f"confinement cost, round trip: x{rt_ratio:.2f} (repeats {rt_lo:.2f}-{rt_hi:.2f}); "
          f"load: x{ld_ratio:.2f} (repeats {ld_lo:.2f}-{ld_hi:.2f})")
    sb_med, ref_med = fig("med")[0], fig("ref_med")[0]
    print(f"sandbox_overhead_median: {sb_med - ref_med:.3f} ms")
    print(f"sandbox_vs_inprocess_ratio: {ratio('med', 'ref_med')[0]:.2f} x")
    print(f"sandbox_vs_interleaved_inprocess_ratio: {ratio('med', 'inter_med')[0]:.2f} x")
    print(f"sandbox_transport_median: {fig('empty_med')[0]:.3f} ms")
    print(f"confinement_roundtrip_ratio: {rt_ratio:.2f} x")
    print(f"confinement_load_ratio: {ld_ratio:.2f} x")
    print(f"confinement_install_median: {fig('confine')[0]:.2f} ms")
    print(f"worker_start_median: {fig('ready')[0]:.0f} ms")
    print(f"program_load_median: {fig('load')[0]:.2f} ms")
    print(f"sandbox_roundtrip_median: {sb_med:.3f} ms")


if __name__ == "__main__":
    main()
