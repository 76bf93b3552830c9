"""Open-loop success rates of the scripted policy under the paper's CLIPort disturbances.

5 seeds x 12 episodes (episode seed = 1000 * seed + episode) for stack-in-order with drop
p in {0, 0.15, 0.3}, placement noise q in {1, 2, 3} cm, and for sweep-half. The paper's CLIPort
column for comparison: 100, 56.7, 21.7, 90.0, 41.7, 15.0 and 0 %. Expected: the same trend
(disturbances hurt; sweep-half fails open loop).

    .venv/bin/python benchmarks/open_loop_success.py [--quick] [--seeds 5] [--episodes 12]

Prints progress, then per-setting mean +- std over seeds, then one line per figure
``open_loop_success_<setting>: value %``. A full run takes several minutes (sweep-half dominates).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

from code_as_monitor.sim.episode import run_open_loop

SETTINGS: list[tuple[str, str, dict]] = [
    ("stack_p0", "stack-in-order", {"p": 0.0}),
    ("stack_p0.15", "stack-in-order", {"p": 0.15}),
    ("stack_p0.3", "stack-in-order", {"p": 0.3}),
    ("stack_q1", "stack-in-order", {"q": 1.0}),
    ("stack_q2", "stack-in-order", {"q": 2.0}),
    ("stack_q3", "stack-in-order", {"q": 3.0}),
    ("sweep_half", "sweep-half", {}),
]
PAPER = {"stack_p0": 100.0, "stack_p0.15": 56.67, "stack_p0.3": 21.67, "stack_q1": 90.0, "stack_q2": 41.67,
         "stack_q3": 15.0, "sweep_half": 0.0}


def main() -> None:
    ap = argparse.ArgumentParser(description="open-loop success rates under disturbances")
    ap.add_argument("--quick", action="store_true", help="2 seeds x 3 episodes")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--episodes", type=int, default=12)
    ap.add_argument("--only", default="", help="comma-separated setting names to run")
    args = ap.parse_args()
    seeds, episodes = (2, 3) if args.quick else (args.seeds, args.episodes)
    settings = [s for s in SETTINGS if not args.only or s[0] in args.only.split(",")]
    results: dict[str, list[float]] = {}
    t_start = time.perf_counter()
    for label, task, cfg in settings:
        per_seed = []
        exec_t = []
        for seed in range(seeds):
            ok = 0
            for ep in range(episodes):
                res = run_open_loop(task, seed=1000 * seed + ep, **cfg)
                ok += res.success
                exec_t.append(res.t)
            per_seed.append(100.0 * ok / episodes)
            print(f"[{time.perf_counter() - t_start:6.1f} s] {label} seed {seed}: {per_seed[-1]:.1f} %",
                  file=sys.stderr, flush=True)
        results[label] = per_seed
        sd = statistics.stdev(per_seed) if len(per_seed) > 1 else 0.0
        print(f"{label}: {statistics.mean(per_seed):.1f} +- {sd:.1f} % over {seeds} seeds x {episodes} episodes "
              f"(paper CLIPort {PAPER[label]:.1f} %; median episode sim time {statistics.median(exec_t):.1f} s)")
    for label, per_seed in results.items():
        print(f"open_loop_success_{label}: {statistics.mean(per_seed):.1f} %")


if __name__ == "__main__":
    main()
