"""``cam run``: one closed-loop Code-as-Monitor episode on any simulator task.

    cam run stack-in-order --seed 3 --p 0.3
    cam run stack-in-order --q 2 --tracker sim
    cam run sweep-half --backend openai --model gpt-4o
    cam run stack-in-order --backend openai --base-url http://localhost:8000/v1 --model qwen2-vl --api-key-env none

Writes a fresh runs/<id>/ with episode.mp4, prompts/, programs/, events.jsonl, ground_truth.jsonl and
summary.json. The default backend `kb` is a rule-based stand-in for a VLM (not a VLM).
"""

from __future__ import annotations

import argparse
from typing import Any

from code_as_monitor.cli import validate as v
from code_as_monitor.core.errors import ConfigError


def add_common(p: argparse.ArgumentParser) -> None:
    """Options shared by ``cam run`` and ``cam demo``."""
    p.add_argument("--seed", type=v.seed, default=None, help="episode seed")
    p.add_argument("--p", type=v.probability, default=None, help="drop probability per decision step (stack-in-order)")
    p.add_argument("--q", type=v.non_negative, default=None, help="placement noise bound in cm (stack-in-order)")
    p.add_argument("--backend", default="kb",
                   help="VLM backend: kb (offline rule-based stand-in, default), openai, replay")
    p.add_argument("--base-url", default=None, help="OpenAI-compatible server URL (openai backend)")
    p.add_argument("--model", default=None, help="model name (openai backend)")
    p.add_argument("--api-key-env", default=None,
                   help="environment variable holding the API key (default OPENAI_API_KEY; 'none' for none)")
    p.add_argument("--cassette", type=v.input_file, default=None, help="JSONL cassette (replay backend)")
    p.add_argument("--segmenter", default="sim", help="segmenter: sim (ground-truth masks, default), color, http")
    p.add_argument("--tracker", default="lk", help="tracker: lk (OpenCV Lucas-Kanade, default), sim (oracle)")
    p.add_argument("--size", default="640x480", help="camera resolution WxH (default 640x480)")
    p.add_argument("--camera-hz", type=v.positive, default=10.0, help="monitoring/camera rate, Hz (default 10)")
    p.add_argument("--no-video", action="store_true", help="do not write episode.mp4")
    p.add_argument("--runs", type=v.output_dir, default="runs", help="parent of the run directory (default runs/)")
    p.add_argument("--max-replans", type=v.count(0), default=30, help="failed subgoals allowed (default 30)")
    p.add_argument("--quiet", action="store_true", help="print only the outcome")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("run", help="run one closed-loop Code-as-Monitor episode on a task",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("task", help="simulator task id (see `cam sim --list`)")
    add_common(p)
    p.set_defaults(func=run)


def config_from_args(args: argparse.Namespace, task: str, default_seed: int = 0,
                     default_params: dict[str, Any] | None = None) -> Any:
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig

    w, sep, h = str(args.size).lower().partition("x")
    if not sep or not w.isdigit() or not h.isdigit():
        raise ConfigError(f"--size must look like 640x480, got {args.size!r}")
    params = dict(default_params or {})
    if args.p is not None:
        params["p"] = args.p
    if args.q is not None:
        params["q"] = args.q
    backend_options: dict[str, Any] = {}
    if args.backend == "openai":
        for key, val in (("base_url", args.base_url), ("model", args.model), ("api_key_env", args.api_key_env)):
            if val is not None:
                backend_options[key] = val
    elif args.backend == "replay":
        if args.cassette is None:
            raise ConfigError("--backend replay needs --cassette PATH")
        backend_options["cassette"] = str(args.cassette)
    elif args.base_url or args.model:
        raise ConfigError(f"--base-url/--model apply to the openai backend, not {args.backend!r}")
    return ClosedLoopConfig(
        task=task, seed=default_seed if args.seed is None else args.seed, task_params=params,
        backend=args.backend, backend_options=backend_options, segmenter=args.segmenter, tracker=args.tracker,
        width=int(w), height=int(h), camera_hz=args.camera_hz, video=not args.no_video,
        max_replans=args.max_replans,
    )


def execute(args: argparse.Namespace, cfg: Any) -> int:
    """Run ``cfg`` into a fresh run directory with the live log; returns the exit code (0 success, 1 failure)."""
    from rich.console import Console

    from code_as_monitor.bench.closed_loop import check_choices, run_closed_loop
    from code_as_monitor.cli.live_log import LiveLog
    from code_as_monitor.core.run_io import new_run_dir

    check_choices(cfg)  # a bad name is a one-line error before any run directory exists
    console = Console(highlight=False)
    run_dir = new_run_dir(args.runs, prefix=f"{cfg.task}-s{cfg.seed}")
    if cfg.backend == "kb":
        console.print("[dim]planner and coder: kb, a rule-based stand-in for a VLM (not a VLM)[/]")
    console.print(f"[dim]segmenter {cfg.segmenter}, tracker {cfg.tracker}, {cfg.width}x{cfg.height} at "
                  f"{cfg.camera_hz:g} Hz; writing {run_dir}/[/]")
    log = LiveLog(console, verbose=args.verbose > 0)
    summary = run_closed_loop(cfg, run_dir, on_event=None if args.quiet else log)
    if args.quiet:
        log.outcome({"success": summary["success"], "reason": summary["reason"],
                     "sim_time_s": summary["sim_time_s"], "vlm": summary["vlm"]["episode"]})
    console.print(f"[dim]wall time {summary['wall_time_s']:.1f} s; artefacts in {run_dir}/[/]")
    return 0 if summary["success"] else 1


def run(args: argparse.Namespace) -> int:
    return execute(args, config_from_args(args, args.task))
