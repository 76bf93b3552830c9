"""Benchmark: benchmark episodes per hour of each method, in this process, without videos.

Runs ``--episodes`` episodes (seed index 0) of every method on each ``--conditions`` cell and reports
episodes per hour of one core (wall time of the episodes alone; the process pool of ``cam bench``
runs one episode per core). Offline: the kb planner, and for the baselines the ``vqa-standin``
single-image stand-in (not a VLM). Also prints frames rendered per episode for the baselines (a method
renders only the frames it uses: open-loop none, inner-monologue at subgoal ends, doremi every k s).

Run: ``.venv/bin/python benchmarks/bench_throughput.py [--conditions stack-p0.15,rope] [--episodes 2]``.
The last lines are machine-readable: ``episodes_per_hour <method>: <n>``.
"""

from __future__ import annotations

import argparse
import statistics
import sys

from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.protocol import METHODS, Job


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--conditions", default="stack-p0.15", help="comma list of condition ids")
    ap.add_argument("--episodes", type=int, default=2, help="episodes per method and condition")
    ap.add_argument("--methods", default=",".join(METHODS))
    args = ap.parse_args(argv)
    conds = [c for c in args.conditions.split(",") if c]
    rates = {}
    for m in [x for x in args.methods.split(",") if x]:
        walls, frames, sims = [], [], []
        for c in conds:
            for e in range(args.episodes):
                rec = run_episode(Job(m, c, 0, e), EpisodeOptions())
                if rec.get("error"):
                    print(f"  {m} {c} e{e}: error {rec['error']}", file=sys.stderr)
                walls.append(rec["wall_time_s"])
                sims.append(rec["sim_time_s"] or 0.0)
                frames.append(rec["frames"])
        mean = statistics.fmean(walls)
        rates[m] = 3600.0 / mean
        fr = [f for f in frames if f is not None]
        print(f"{m:16s} {mean:6.2f} s wall/episode  {statistics.fmean(sims):6.2f} s sim/episode  "
              f"frames/episode {statistics.fmean(fr) if fr else float('nan'):5.1f}")
    for m, r in rates.items():
        print(f"episodes_per_hour {m}: {r:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
