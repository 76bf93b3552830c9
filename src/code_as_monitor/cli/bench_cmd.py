"""``cam bench``: the CLIPort benchmark (paper Table 1) in our simulator, resumable.

    cam bench --quick                                   # 1 seed x 4 episodes -> runs/bench/cliport-quick.jsonl
    cam bench --results runs/bench/cliport.jsonl        # full: 5 seeds x 12 episodes (resumes)
    cam bench --methods cam,doremi --conditions stack-p0.3,stack-q3 --seeds 2 --episodes 3
    cam bench --executor ray [--ray-address auto]       # needs the `ray` extra
    cam bench --suite rlbench --episodes 20             # RLBench table: 20 valid episodes per cell, restarts
    cam bench --suite ablation                          # ablation rows (MV/CS/CP off, reactive/proactive only)

Per-episode records are appended to --results as they finish; re-running the same command skips
finished episodes made by the same code version (episodes made by other code are run again unless
--keep-stale). One `cam bench` at a time per results file (it is locked). The default results file is
under runs/bench/ (not tracked); the published results are in results/published/ and are never
written by default. Offline (--backend kb) the baselines' VQA is `vqa-standin`, a rule-based
single-image stand-in, not a VLM. Then: cam report <results>.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from code_as_monitor.cli import validate as v
from code_as_monitor.cli.run_cmd import DEFAULT_TRACKER, add_server_options, server_options
from code_as_monitor.core.errors import ConfigError

RESULTS_DIR = Path("runs/bench")
"""Where results go by default (untracked); published results live in results/published/."""


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("bench", help="run the CLIPort benchmark (methods x conditions), resumable",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="1 seed x 4 episodes per condition")
    p.add_argument("--suite", choices=("cliport", "table2", "instructions", "rlbench", "ablation"), default="cliport",
                   help="cliport: the paper's Table 1 conditions (default); table2: its Table 2 layout "
                        "(slot-pen None/(a)/(b)/(c), 10 runs, open-loop and cam); instructions: goals set by "
                        "instructions other than the paper's (open-loop and cam); rlbench: its RLBench table (six "
                        "tasks, a noisy policy, a flagged episode abandoned and another started); ablation: the "
                        "paper's ablation rows on stow-book, slot-pen and pour-tea (None/(a)/(b)/(c), 10 runs), "
                        "methods cam (full), cam-mv-off (front view only), cam-cs-off (elements from ORB keypoints "
                        "on the object's region, lifted and k-means clustered: an offline analogue of the paper's "
                        "DINOv2 points, not DINOv2), cam-cp-off (unconnected points), cam-reactive-only, "
                        "cam-proactive-only")
    p.add_argument("--seeds", type=v.count(1, 1000), default=None, help="seeds per cell (default 5, quick 1)")
    p.add_argument("--episodes", type=v.count(1, 1000), default=None,
                   help="episodes per seed (default 12, quick 4); rlbench: valid episodes per cell (default 20)")
    p.add_argument("--methods", type=v.csv, default=None, help="comma list (default: all four)")
    p.add_argument("--conditions", type=v.csv, default=None, help="comma list of condition ids (default: all)")
    p.add_argument("--results", type=v.results_file, default=None,
                   help="JSONL results file, created or resumed (default runs/bench/<suite>.jsonl, quick: "
                        "runs/bench/<suite>-quick.jsonl)")
    p.add_argument("--keep-stale", action="store_true",
                   help="keep finished episodes made by another code version instead of running them again")
    p.add_argument("--runs-dir", type=v.output_dir, default="runs/bench",
                   help="sample videos go here (seed 0, episode 0 of each cell)")
    p.add_argument("--no-videos", action="store_true", help="record no sample videos")
    p.add_argument("--executor", default="local", help="local (process pool, default) or ray")
    p.add_argument("--workers", type=v.count(0, 1024), default=0, help="episodes at once (default: one per CPU)")
    p.add_argument("--ray-address", default=None, help="existing Ray cluster (default: a local instance)")
    p.add_argument("--backend", default="kb", help="VLM backend: kb (offline stand-in) or openai")
    p.add_argument("--backend-options", type=v.json_object, default={}, help="JSON object of backend options")
    add_server_options(p)
    p.add_argument("--doremi-k", type=v.number(0.0, 3600.0, lo_open=True), default=1.0,
                   help="seconds between DoReMi's VQA checks (default 1)")
    p.add_argument("--tracker", default=DEFAULT_TRACKER, help="CaM tracker: depth (no simulator pose, default), sim "
                   "(the oracle: the simulator's poses), lk; recorded in every result and the report")
    p.add_argument("--segmenter", default="sim", help="CaM segmenter (default sim)")
    p.add_argument("--cameras", default="task",
                   help="the camera set every method sees: task (each task's own views, default), front-top (the "
                        "paper's CLIPort views), front, shoulders, rlbench, or FILE.json (your own views: see "
                        "`cam run --help`); recorded in every result. The baselines ask each question on the set's "
                        "view most like the one they want (steepest for top-down questions, most level for the "
                        "others)")
    p.add_argument("--robot-visual", default="decimated",
                   help="how the cameras draw the arm (the same physics): decimated (its detailed meshes with a "
                        "fifth of their triangles, default: under 1%% of the arm's pixels change, about 40%% less "
                        "render time), mesh (the full detailed meshes) or hull (its collision meshes: less than half "
                        "the render time, a plainer and slightly larger arm in every image); recorded in every result")
    p.add_argument("--no-counterfactual", action="store_true", help="skip counterfactual rollouts")
    p.add_argument("--list", action="store_true", help="list conditions and methods")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from code_as_monitor.bench.executors import ExecutorConfig
    from code_as_monitor.bench.protocol import ALL_METHODS, CONDITIONS, QUICK, SUITE_DEFAULTS, SUITES, BenchSpec
    from code_as_monitor.bench.runner import run_bench
    from code_as_monitor.cli.signals import sigterm_as_interrupt

    if args.list:
        for c in CONDITIONS:
            print(f"{c.id:12s} {c.task} {c.params}{'  (undisturbed)' if c.undisturbed else ''}")
        print("methods:", ", ".join(ALL_METHODS))
        return 0
    suite = SUITE_DEFAULTS[args.suite]
    seeds = args.seeds if args.seeds is not None else (QUICK[0] if args.quick else suite["seeds"])
    episodes = args.episodes if args.episodes is not None else (QUICK[1] if args.quick else suite["episodes"])
    results = args.results or v.check_results_file(
        RESULTS_DIR / f"{args.suite}{'-quick' if args.quick else ''}.jsonl", "--results")
    backend_options = dict(args.backend_options)
    if server_options(args):
        if args.backend != "openai":
            raise ConfigError(f"--timeout/--max-retries/--max-tokens/--no-images/--structured apply to the openai "
                              f"backend, not {args.backend!r}")
        backend_options.update(server_options(args))
    options = {"backend": args.backend, "backend_options": backend_options, "doremi_k_s": args.doremi_k,
               "tracker": args.tracker, "segmenter": args.segmenter, "counterfactual": not args.no_counterfactual,
               "cameras": args.cameras, "robot_visual": args.robot_visual, **suite.get("options", {})}
    kw: dict = {"methods": list(suite["methods"]), "conditions": list(SUITES[args.suite])}
    if args.methods:
        kw["methods"] = args.methods
    if args.conditions:
        kw["conditions"] = args.conditions
    spec = BenchSpec(seeds=seeds, episodes=episodes, options=options, **kw)
    _check_options(options, spec)
    ex_kw: dict = {"workers": args.workers}
    if args.executor == "ray":
        ex_kw["address"] = args.ray_address
    elif args.ray_address is not None:
        raise ConfigError("--ray-address needs --executor ray")
    executor = ExecutorConfig.from_name(args.executor, **ex_kw)
    if args.executor == "ray":
        from code_as_monitor.bench.executors import require_ray

        require_ray()
    runs_dir = None if args.no_videos else args.runs_dir
    if suite.get("restarts"):
        return _run_restarts(spec, results, executor, runs_dir, args, suite["max_attempts_factor"] * episodes)
    # SIGTERM ends a sweep like Ctrl-C: the pool is cancelled and its workers ended, nothing half-written.
    with sigterm_as_interrupt(), _Progress(results) as (on_start, on_result):
        out = run_bench(spec, results, executor, runs_dir, on_result, on_start, keep_stale=args.keep_stale)
    stale = (f", {out['stale']} made by other code {'kept' if args.keep_stale else 'run again'}"
             if out["stale"] else "")
    print(f"{out['ran']} episode(s) run, {out['skipped']} skipped{stale}, {out['wall_s'] / 60:.1f} min -> {results}")
    print(f"report: cam report {results}")
    return 0


def _run_restarts(spec: Any, results: Path, executor: Any, runs_dir: Any, args: argparse.Namespace,
                  max_attempts: int) -> int:
    """The RLBench protocol: rounds of attempts until each cell has ``spec.episodes`` valid episodes."""
    from code_as_monitor.bench.restarts import run_restart_bench
    from code_as_monitor.bench.runner import episode_records, read_results, run_bench
    from code_as_monitor.cli.signals import sigterm_as_interrupt

    with sigterm_as_interrupt(), _Progress(results) as (on_start, on_result):
        out = run_restart_bench(
            spec, results, spec.episodes, max_attempts,
            run_round=lambda sp: run_bench(sp, results, executor, runs_dir, on_result, on_start,
                                           keep_stale=args.keep_stale),
            read=lambda: episode_records(read_results(results)))
    short = "; ".join(f"{c}/{m}" for c, m, _ in out["incomplete"])
    print(f"{out['rounds']} round(s) -> {results}"
          + (f"; short of {spec.episodes} valid episodes at {max_attempts} attempts: {short}" if short else ""))
    print(f"report: cam report {results}")
    return 0


def _check_options(options: dict[str, Any], spec: Any) -> None:
    """The method options as the episodes will see them: unknown backends/trackers/segmenters, or an ablation
    keeping a view the camera set lacks, are one line now, not an error record per episode later."""
    from code_as_monitor.agent.ablations import ablation_fields
    from code_as_monitor.bench.episode import EpisodeOptions
    from code_as_monitor.bench.protocol import ablation_of, is_cam
    from code_as_monitor.perception import SegmenterConfig, TrackerConfig
    from code_as_monitor.sim.cameras import check_views_kept
    from code_as_monitor.vlm import VLMBackendConfig

    EpisodeOptions(**options)
    VLMBackendConfig.from_name(options["backend"], **options["backend_options"])
    TrackerConfig.get_class(options["tracker"])
    SegmenterConfig.get_class(options["segmenter"])
    check_views_kept(options["cameras"], None, "")  # an unknown set, also when no method keeps a view
    for m in spec.methods:
        if is_cam(m):
            check_views_kept(options["cameras"], ablation_fields(ablation_of(m)).get("cameras"), f"method {m!r}")


class _Progress:
    """Context giving ``(on_start, on_result)`` callbacks: a rich bar on a terminal, else plain lines."""

    def __init__(self, results: Path) -> None:
        self.results = results
        self.bar: Any = None

    def __enter__(self) -> tuple[Any, Any]:
        from code_as_monitor.cli.progress import ProgressLines, is_terminal

        results = self.results
        if not is_terminal():
            lines = ProgressLines("cam bench", "episodes")

            def on_start_plain(pending: int, skipped: int) -> None:
                lines.start(pending)
                note = f" ({skipped} finished episode(s) skipped)" if skipped else ""
                print(f"cam bench: {pending} episode(s) to run -> {results}{note}", flush=True)

            def on_result_plain(job: Any, rec: dict[str, Any], done: int, total: int) -> None:
                lines.update(done, f"{job.condition} {job.method} s{job.seed}e{job.episode} {_mark(rec)}")

            return on_start_plain, on_result_plain
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.bar = bar = Progress(TextColumn("[bold]cam bench"), BarColumn(), MofNCompleteColumn(),
                                  TimeElapsedColumn(), TimeRemainingColumn(), TextColumn("{task.description}"))
        bar.__enter__()
        task = bar.add_task("", total=None)

        def on_start(pending: int, skipped: int) -> None:
            bar.update(task, total=pending)
            if skipped:
                bar.console.print(f"resuming {results}: {skipped} finished episode(s) skipped")

        def on_result(job: Any, rec: dict[str, Any], done: int, total: int) -> None:
            bar.update(task, completed=done,
                       description=f"{job.condition} {job.method} s{job.seed}e{job.episode} {_mark(rec)}")

        return on_start, on_result

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)


def _mark(rec: dict[str, Any]) -> str:
    return "ok" if rec.get("success") else ("ERROR" if rec.get("error") else "fail")
