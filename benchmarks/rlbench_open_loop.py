"""Open-loop success of the RLBench-style tasks under the learned-policy analogue (the policy's action noise).

Usage: ``.venv/bin/python benchmarks/rlbench_open_loop.py [--seeds 100] [--first 1000] [--noise 1.0]
[--tasks put-in-drawer,...]``. Seeds ``first .. first + seeds - 1`` (kept apart from the benchmark protocol's
hashed episode seeds). Per task: successes / runs beside the paper's ARP column, the ground-truth
``policy_failure`` kinds, and how often a failed episode has no failure event and a successful one has one
(the ground truth's agreement with the task's success check). Ends with ``name: value unit`` lines.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

from code_as_monitor.sim.episode import run_open_loop

TASKS = ("open-drawer", "put-in-drawer", "screw-bulb", "turn-tap", "drag-stick", "sweep-to-dustpan")
ARP = {"open-drawer": 93.9, "put-in-drawer": 91.0, "screw-bulb": 86.4, "turn-tap": 96.6, "drag-stick": 88.1,
       "sweep-to-dustpan": 91.6}
"""The paper's ARP success rates (%), Table "Performance in RLBench"."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--first", type=int, default=1000)
    ap.add_argument("--noise", type=float, default=1.0)
    ap.add_argument("--tasks", default=",".join(TASKS))
    args = ap.parse_args()
    for task in args.tasks.split(","):
        t0 = time.perf_counter()
        ok, whats, silent, spurious = 0, Counter(), 0, 0
        for s in range(args.first, args.first + args.seeds):
            r = run_open_loop(task, seed=s, noise=args.noise)
            fails = [e["what"] for e in r.events if e["kind"] == "policy_failure"]
            ok += r.success
            whats.update(fails)
            silent += (not r.success) and not fails
            spurious += r.success and bool(fails)
        rate = 100.0 * ok / args.seeds
        print(f"{task:17s} {ok}/{args.seeds} = {rate:5.1f} % (ARP {ARP[task]:.1f} %)  failures {dict(whats)}  "
              f"failed without an event {silent}, succeeded with one {spurious}  "
              f"wall {time.perf_counter() - t0:5.0f} s", flush=True)
        print(f"{task}_open_loop_success: {rate:.1f} %")


if __name__ == "__main__":
    main()
