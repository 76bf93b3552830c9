"""``cam run``: one closed-loop Code-as-Monitor episode on any simulator task.

    cam run stack-in-order --seed 3 --p 0.3
    cam run stack-in-order --q 2 --tracker sim
    cam run slot-pen --set disturbance=a --tracker depth --cameras shoulders
    cam run sweep-half --backend openai --model gpt-4o
    cam run stack-in-order --backend openai --base-url http://localhost:8000/v1 --model qwen2-vl --api-key-env none

Writes a fresh runs/<id>/ with episode.mp4, prompts/, programs/, events.jsonl, ground_truth.jsonl and
summary.json. The default backend `kb` is a rule-based stand-in for a VLM (not a VLM).

Exit codes (summary.json's "outcome" says the same):
  0  success      the task's success check passed
  1  failure      the episode ran and the task failed
  2  bad input    a bad argument, name or configuration (incl. a missing API key); no run dir is made
  3  error        the run stopped early: the planner's backend failed, or an error was found late
  130 interrupted Ctrl-C or SIGTERM; summary.json is still written
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from code_as_monitor.agent.ablations import ABLATIONS
from code_as_monitor.cli import validate as v
from code_as_monitor.core.checks import DEADLINE_S_RANGE, IMAGE_SIDE_RANGE, RATE_HZ_RANGE
from code_as_monitor.core.errors import ConfigError

DEFAULT_TRACKER = "depth"
"""The tracker of ``cam run`` / ``cam demo`` / ``cam monitor`` / ``cam bench`` when none is named (issue #12 §4)."""


def add_common(p: argparse.ArgumentParser) -> None:
    """Options shared by ``cam run``, ``cam demo`` and ``cam record``."""
    p.add_argument("--seed", type=v.seed, default=None, help="episode seed")
    p.add_argument("--p", type=v.probability, default=None, help="drop probability per decision step (stack-in-order)")
    p.add_argument("--q", type=v.non_negative, default=None, help="placement noise bound in cm (stack-in-order)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any task config field (VALUE parsed as JSON, else a string; see `cam sim --list`), e.g. "
                        "--set disturbance=a for slot-pen; repeatable")
    p.add_argument("--instruction", default=None,
                   help="the instruction for the agent (default: the task's own); the task's goal and success "
                        "check follow it, e.g. --instruction \"stack red on top of green on top of blue\"")
    add_monitor_options(p)
    p.add_argument("--size", default="640x480", help="camera resolution WxH (default 640x480)")
    p.add_argument("--cameras", default="task",
                   help="camera set: task (the task's own views, default), front-top (the paper's CLIPort views), "
                        "front (the front view alone), shoulders (two views over the robot's shoulders), rlbench "
                        "(front, both shoulders, wrist), or FILE.json: your own views (a list of {name, eye, "
                        "target[, fov_y_deg, up, mount, width, height]}, world frame, metres; see "
                        "code_as_monitor.sim.camera_file)")
    p.add_argument("--robot-visual", default="decimated",
                   help="how the cameras draw the arm (the same physics): decimated (its detailed meshes with a "
                        "fifth of their triangles, default: under 1%% of the arm's pixels change, about 40%% less "
                        "render time), mesh (the full detailed meshes) or hull (its collision meshes: less than half "
                        "the render time, a plainer and slightly larger arm in every image)")


def add_monitor_options(p: argparse.ArgumentParser, segmenter: str = "sim") -> None:
    """The monitor's options (backend, perception, rate, outputs), shared with ``cam monitor``."""
    p.add_argument("--backend", default="kb",
                   help="VLM backend: kb (offline rule-based stand-in, default), openai, replay")
    p.add_argument("--base-url", default=None, help="OpenAI-compatible server URL (openai backend)")
    p.add_argument("--model", default=None, help="model name (openai backend)")
    p.add_argument("--api-key-env", default=None,
                   help="environment variable holding the API key (default OPENAI_API_KEY; 'none' for none)")
    p.add_argument("--cassette", type=v.input_file, default=None, help="JSONL cassette (replay backend)")
    add_server_options(p)
    p.add_argument("--segmenter", default=segmenter,
                   help=f"segmenter: sim (ground-truth masks), color, http (default {segmenter})")
    p.add_argument("--tracker", default=DEFAULT_TRACKER,
                   help="tracker: depth (each object's points registered to the depth images with small_gicp; "
                        "default), lk (OpenCV Lucas-Kanade), sim (the oracle: the simulator's poses)")
    p.add_argument("--camera-hz", type=v.number(*RATE_HZ_RANGE), default=10.0,
                   help="monitoring/camera rate, Hz (default 10; the simulator renders at most 40)")
    p.add_argument("--no-video", action="store_true", help="do not write episode.mp4")
    p.add_argument("--runs", type=v.output_dir, default="runs", help="parent of the run directory (default runs/)")
    p.add_argument("--max-replans", type=v.count(0, 10_000), default=30, help="failed subgoals allowed (default 30)")
    p.add_argument("--deadline", type=v.number(*DEADLINE_S_RANGE), default=0.020,
                   help="seconds all checks of one frame may take in the sandbox before that frame is a fault "
                        "(default 0.02, a real-time budget; the benchmark uses 0.5: in the simulator time waits "
                        "for the monitor, and a tight wall-clock budget makes results depend on the machine's load)")
    p.add_argument("--allow-unconfined", action="store_true",
                   help="run generated monitor code even where the sandbox cannot install its kernel confinement "
                        "(seccomp, no_new_privs, namespaces); without it such a machine refuses, saying why")
    p.add_argument("--ablation", choices=tuple(ABLATIONS), default="full",
                   help="an ablation setting of the monitor (default full): mv-off (front view only), cs-off "
                        "(elements from ORB keypoints on the object's region, lifted and k-means clustered: our "
                        "offline analogue of the paper's DINOv2 points, not DINOv2), cp-off (unconnected points, "
                        "no lines or surfaces), reactive-only, proactive-only (only the constraints marked so)")
    p.add_argument("--quiet", action="store_true", help="print only the outcome")
    p.add_argument("--rerun", nargs="?", const="save", default=None, choices=("save", "spawn", "connect"),
                   help="live 3-D view with rerun-sdk (the [rerun] extra): save run.rrd in the run dir (default), "
                        "spawn a viewer, or connect to one (--rerun-url)")
    p.add_argument("--rerun-url", default=None, help="viewer gRPC URL for --rerun connect (default: rerun's)")


def add_server_options(p: argparse.ArgumentParser) -> None:
    """Options of a real model server (the openai backend), shared by run, demo, bench and plan."""
    p.add_argument("--timeout", type=v.number(0.0, 3600.0, lo_open=True), default=None,
                   help="seconds a model request may take before it is given up and closed (openai; default 120; "
                        "a CPU server needs minutes)")
    p.add_argument("--max-retries", type=v.count(0, 100), default=None,
                   help="retries on 429/5xx/connection errors (openai; default 3)")
    p.add_argument("--max-tokens", type=v.count(1, 10_000_000), default=None,
                   help="longest answer, tokens (openai; default 2048; prompt + this must fit the server's context)")
    p.add_argument("--no-images", action="store_true", help="send no images (openai; for a text-only model)")
    p.add_argument("--structured", choices=("auto", "json_schema", "json_object", "off"), default=None,
                   help="structured output asked of the server (openai; default auto: JSON schema, falling back "
                        "to prompt-only JSON)")


def server_options(args: argparse.Namespace) -> dict[str, Any]:
    """The openai backend options given on the command line."""
    out: dict[str, Any] = {}
    for key, val in (("timeout_s", args.timeout), ("max_retries", args.max_retries),
                     ("max_tokens", args.max_tokens), ("structured", args.structured)):
        if val is not None:
            out[key] = val
    if args.no_images:
        out["images"] = False
    return out


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
    lo, hi = IMAGE_SIDE_RANGE
    if not (lo <= int(w) <= hi and lo <= int(h) <= hi):
        raise ConfigError(f"--size: width and height must be in [{lo}, {hi}] pixels, got {args.size!r}")
    params = dict(default_params or {})
    params.update(v.parse_settings(getattr(args, "set", None) or []))
    if args.p is not None:
        params["p"] = args.p
    if args.q is not None:
        params["q"] = args.q
    if args.instruction is not None:
        if not args.instruction.strip():
            raise ConfigError("--instruction is empty")
        params["instruction"] = args.instruction
    return ClosedLoopConfig(
        task=task, seed=default_seed if args.seed is None else args.seed, task_params=params,
        backend=args.backend, backend_options=backend_options_from_args(args), segmenter=args.segmenter,
        tracker=args.tracker, width=int(w), height=int(h), camera_hz=args.camera_hz, video=not args.no_video,
        max_replans=args.max_replans, deadline_s=args.deadline, allow_unconfined=args.allow_unconfined,
        ablation=args.ablation, cameras=args.cameras, robot_visual=args.robot_visual,
    )


def backend_options_from_args(args: argparse.Namespace) -> dict[str, Any]:
    """The VLM backend's options from ``--base-url``, ``--model``, ``--api-key-env``, ``--cassette`` and the
    server options (``--timeout`` ...)."""
    backend_options: dict[str, Any] = {}
    for flag, val in (("--base-url", args.base_url), ("--model", args.model), ("--api-key-env", args.api_key_env)):
        if val is not None and not val.strip():
            raise ConfigError(f"{flag} is empty")
    server = server_options(args)
    if args.backend == "openai":
        for key, val in (("base_url", args.base_url), ("model", args.model), ("api_key_env", args.api_key_env)):
            if val is not None:
                backend_options[key] = val
        backend_options.update(server)
    elif server:
        raise ConfigError(f"--timeout/--max-retries/--max-tokens/--no-images/--structured apply to the openai "
                          f"backend, not {args.backend!r}")
    if args.backend == "replay":
        if args.cassette is None:
            raise ConfigError("--backend replay needs --cassette PATH")
        backend_options["cassette"] = str(args.cassette)
    elif args.backend != "openai" and (args.base_url or args.model or args.api_key_env):
        raise ConfigError(f"--base-url/--model/--api-key-env apply to the openai backend, not {args.backend!r}")
    return backend_options


EXIT_CODES = {"success": 0, "failure": 1, "error": 3, "interrupted": 130}
"""Exit code of ``cam run`` for each outcome (2 is a bad input found before the run started)."""


def execute(args: argparse.Namespace, cfg: Any) -> int:
    """Run ``cfg`` into a fresh run directory with the live log; returns the exit code (see EXIT_CODES)."""
    import sys

    from rich.console import Console

    from code_as_monitor.bench.closed_loop import early_end, make_checked_backend, run_closed_loop
    from code_as_monitor.cli.live_log import LiveLog
    from code_as_monitor.cli.signals import sigterm_as_interrupt
    from code_as_monitor.core.run_io import new_run_dir

    # Every name is checked and the backend built (a missing API key found) before a run dir exists.
    check_extras(args)
    backend = make_checked_backend(cfg)
    console = Console(highlight=False)
    run_dir = new_run_dir(args.runs, prefix=f"{cfg.task}-s{cfg.seed}")
    if cfg.backend == "kb":
        console.print("[dim]planner and coder: kb, a rule-based stand-in for a VLM (not a VLM)[/]")
    console.print(f"[dim]segmenter {cfg.segmenter}, tracker {cfg.tracker}, {cfg.width}x{cfg.height} at "
                  f"{cfg.camera_hz:g} Hz; writing {run_dir}/[/]")
    log = LiveLog(console, verbose=args.verbose > 0)
    hooks = extra_hooks(args, run_dir)
    try:
        with sigterm_as_interrupt():
            summary = run_closed_loop(cfg, run_dir, on_event=chain_events(None if args.quiet else log, hooks),
                                      backend=backend, frame_hooks=hooks.frame_hooks)
    except BaseException as exc:  # summary.json is written; say how the run ended in one line
        outcome, reason = early_end(exc)
        print(f"cam {args.command}: {outcome}: {reason} (summary in {run_dir}/summary.json)", file=sys.stderr)
        return EXIT_CODES[outcome]
    finally:
        hooks.close()
    if summary["outcome"] == "error":
        print(f"cam {args.command}: error: {summary['error']} (summary in {run_dir}/summary.json)",
              file=sys.stderr)
    elif args.quiet:
        log.outcome({"success": summary["success"], "reason": summary["reason"],
                     "sim_time_s": summary["sim_time_s"], "vlm": summary["vlm"]["episode"]})
    console.print(f"[dim]wall time {summary['wall_time_s']:.1f} s; artefacts in {run_dir}/[/]")
    return EXIT_CODES[summary["outcome"]]


class Hooks:
    """The optional live view's callbacks (``--rerun``): frame hooks, an event hook, and its closer."""

    def __init__(self, logger: Any = None) -> None:
        self.logger = logger
        self.frame_hooks = [logger.on_frame] if logger is not None else []
        self.on_event = logger.on_event if logger is not None else None

    def close(self) -> None:
        if self.logger is not None:
            self.logger.close()


def check_extras(args: argparse.Namespace) -> None:
    """MissingExtraError (one line, exit 2) for an asked-for extra that is not installed, before any run dir."""
    from code_as_monitor.core.extras import require

    if getattr(args, "rerun", None):
        require("rerun", "rerun")
    if getattr(args, "rerun_url", None):
        if getattr(args, "rerun", None) != "connect":
            raise ConfigError("--rerun-url applies to --rerun connect")
        from code_as_monitor.viz.rerun_log import check_url

        check_url(args.rerun_url)


def extra_hooks(args: argparse.Namespace, run_dir: Path) -> Hooks:
    """The live view (``--rerun``) for a run writing to ``run_dir``."""
    if not getattr(args, "rerun", None):
        return Hooks()
    from code_as_monitor.viz.rerun_log import RerunLogger

    return Hooks(RerunLogger(args.rerun, path=run_dir / "run.rrd", url=args.rerun_url))


def chain_events(first: Any, hooks: Hooks) -> Any:
    """One ``on_event`` callback calling ``first`` (the live log) and the live view's, either may be None."""
    calls = [f for f in (first, hooks.on_event) if f is not None]
    if not calls:
        return None

    def on_event(ev: dict[str, Any]) -> None:
        for f in calls:
            f(ev)

    return on_event


def run(args: argparse.Namespace) -> int:
    return execute(args, config_from_args(args, args.task))
