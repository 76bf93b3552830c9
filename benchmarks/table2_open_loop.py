"""Open-loop success per Table 2 condition (None, (a), (b), (c)) of the gripper tasks, 10 seeds each.

Usage: ``.venv/bin/python benchmarks/table2_open_loop.py [--seeds 10]``. Prints one line per condition:
task, condition, task_params, successes / runs, mean sim time of the episodes.
"""

from __future__ import annotations

import argparse
import time

from code_as_monitor.sim.episode import run_open_loop

CONDITIONS: dict[str, dict[str, dict[str, str]]] = {
    "slot-pen": {"None": {}, "(a)": {"disturbance": "a"}, "(b)": {"disturbance": "b"}, "(c)": {"disturbance": "c"}},
}
"""Task -> condition label -> task_params (the bench protocol's conditions for Table 2)."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args()
    for task, conds in CONDITIONS.items():
        for label, params in conds.items():
            t0 = time.perf_counter()
            runs = [run_open_loop(task, seed=s, **params) for s in range(args.seeds)]
            ok = sum(r.success for r in runs)
            mean_t = sum(r.t for r in runs) / len(runs)
            print(f"{task:10s} {label:5s} {params!s:28s} {ok}/{len(runs)}  sim {mean_t:5.1f} s  "
                  f"wall {time.perf_counter() - t0:5.1f} s", flush=True)


if __name__ == "__main__":
    main()
