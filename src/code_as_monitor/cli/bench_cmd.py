"""``cam bench``: the CLIPort benchmark (paper Table 1) in our simulator, resumable.

    cam bench --quick                                   # 1 seed x 4 episodes per condition
    cam bench --results results/cliport.jsonl           # full: 5 seeds x 12 episodes (resumes)
    cam bench --methods cam,doremi --conditions stack-p0.3,stack-q3 --seeds 2 --episodes 3
    cam bench --executor ray [--ray-address auto]       # needs the `ray` extra

Per-episode records are appended to --results as they finish; re-running the same command skips
finished episodes. Offline (--backend kb) the baselines' VQA is `vqa-standin`, a rule-based
single-image stand-in, not a VLM. Then: cam report <results>.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from code_as_monitor.core.errors import ConfigError


def _csv(s: str) -> list[str]:
    return [x.strip() for x in s.split(",") if x.strip()]


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("bench", help="run the CLIPort benchmark (methods x conditions), resumable",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="1 seed x 4 episodes per condition")
    p.add_argument("--suite", choices=("cliport", "table2"), default="cliport",
                   help="cliport: the paper's Table 1 conditions (default); table2: its Table 2 layout "
                        "(slot-pen None/(a)/(b)/(c), 10 runs, open-loop and cam)")
    p.add_argument("--seeds", type=int, default=None, help="seeds per cell (default 5, quick 1)")
    p.add_argument("--episodes", type=int, default=None, help="episodes per seed (default 12, quick 4)")
    p.add_argument("--methods", type=_csv, default=None, help="comma list (default: all four)")
    p.add_argument("--conditions", type=_csv, default=None, help="comma list of condition ids (default: all)")
    p.add_argument("--results", type=Path, default=None,
                   help="JSONL results file (default results/cliport.jsonl, quick: results/cliport-quick.jsonl)")
    p.add_argument("--runs-dir", type=Path, default=Path("runs/bench"),
                   help="sample videos go here (seed 0, episode 0 of each cell)")
    p.add_argument("--no-videos", action="store_true", help="record no sample videos")
    p.add_argument("--executor", default="local", help="local (process pool, default) or ray")
    p.add_argument("--workers", type=int, default=0, help="episodes at once (default: one per CPU)")
    p.add_argument("--ray-address", default=None, help="existing Ray cluster (default: a local instance)")
    p.add_argument("--backend", default="kb", help="VLM backend: kb (offline stand-in) or openai")
    p.add_argument("--backend-options", type=json.loads, default={}, help="JSON object of backend options")
    p.add_argument("--doremi-k", type=float, default=1.0, help="seconds between DoReMi's VQA checks (default 1)")
    p.add_argument("--tracker", default="sim", help="CaM tracker: sim (oracle, default), lk, depth; recorded in every "
                   "result and the report")
    p.add_argument("--segmenter", default="sim", help="CaM segmenter (default sim)")
    p.add_argument("--no-counterfactual", action="store_true", help="skip counterfactual rollouts")
    p.add_argument("--list", action="store_true", help="list conditions and methods")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from code_as_monitor.bench.executors import ExecutorConfig
    from code_as_monitor.bench.protocol import CONDITIONS, METHODS, QUICK, SUITE_DEFAULTS, SUITES, BenchSpec
    from code_as_monitor.bench.runner import run_bench

    if args.list:
        for c in CONDITIONS:
            print(f"{c.id:12s} {c.task} {c.params}{'  (undisturbed)' if c.undisturbed else ''}")
        print("methods:", ", ".join(METHODS))
        return 0
    suite = SUITE_DEFAULTS[args.suite]
    seeds = args.seeds or (QUICK[0] if args.quick else suite["seeds"])
    episodes = args.episodes or (QUICK[1] if args.quick else suite["episodes"])
    results = args.results or Path(f"results/{args.suite}{'-quick' if args.quick else ''}.jsonl")
    options = {"backend": args.backend, "backend_options": args.backend_options, "doremi_k_s": args.doremi_k,
               "tracker": args.tracker, "segmenter": args.segmenter, "counterfactual": not args.no_counterfactual}
    kw: dict = {"methods": list(suite["methods"]), "conditions": list(SUITES[args.suite])}
    if args.methods:
        kw["methods"] = args.methods
    if args.conditions:
        kw["conditions"] = args.conditions
    spec = BenchSpec(seeds=seeds, episodes=episodes, options=options, **kw)
    ex_kw: dict = {"workers": args.workers}
    if args.executor == "ray":
        ex_kw["address"] = args.ray_address
    elif args.ray_address:
        raise ConfigError("--ray-address needs --executor ray")
    executor = ExecutorConfig.from_name(args.executor, **ex_kw)
    results.parent.mkdir(parents=True, exist_ok=True)

    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn("[bold]cam bench"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TimeRemainingColumn(), TextColumn("{task.description}")) as bar:
        task = bar.add_task("", total=None)

        def on_start(pending: int, skipped: int) -> None:
            bar.update(task, total=pending)
            if skipped:
                bar.console.print(f"resuming {results}: {skipped} finished episode(s) skipped")

        def on_result(job, rec, done: int, total: int) -> None:
            mark = "ok" if rec.get("success") else ("ERROR" if rec.get("error") else "fail")
            bar.update(task, completed=done,
                       description=f"{job.condition} {job.method} s{job.seed}e{job.episode} {mark}")

        out = run_bench(spec, results, executor, None if args.no_videos else args.runs_dir, on_result, on_start)
    print(f"{out['ran']} episode(s) run, {out['skipped']} skipped, {out['wall_s'] / 60:.1f} min -> {results}")
    print(f"report: cam report {results}")
    return 0
