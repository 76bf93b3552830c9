"""``cam sim``: run one open-loop simulator episode, or list the tasks.

    cam sim stack-in-order --seed 3 --p 0.3 --video out.mp4     # writes out.mp4 + out.events.jsonl
    cam sim turn-tap --cameras my_views.json --video views.mp4  # what your own cameras see
    cam sim sweep-half --set zone_half=0.1 --events ev.jsonl
    cam sim --list
"""

from __future__ import annotations

import argparse
import json

from code_as_monitor.cli import validate as v
from code_as_monitor.core.checks import RATE_HZ_RANGE, SIM_CONTROL_HZ
from code_as_monitor.core.errors import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("sim", help="run one open-loop simulator episode (or --list the tasks)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("task", nargs="?", help="task id (see --list)")
    p.add_argument("--list", action="store_true", help="list the tasks and their parameters")
    p.add_argument("--seed", type=v.seed, default=0, help="episode seed (default 0)")
    p.add_argument("--p", type=v.probability, default=None, help="drop probability per decision (stack-in-order)")
    p.add_argument("--q", type=v.non_negative, default=None, help="placement noise bound, cm (stack-in-order)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="any task config field (VALUE parsed as JSON, else a string); repeatable")
    p.add_argument("--video", type=v.new_file, default=None, help="write an mp4 of the views here (tiled)")
    p.add_argument("--cameras", default="task",
                   help="the views of the video: task (the task's own, default), front-top, front, shoulders, "
                        "rlbench, or FILE.json (your own views, as `cam run --cameras`: check a camera file here)")
    p.add_argument("--events", type=v.new_file, default=None,
                   help="ground-truth event log (JSONL); default: next to --video as <stem>.events.jsonl")
    p.add_argument("--renderer", choices=("tiny", "egl"), default="tiny", help="renderer (default tiny)")
    p.add_argument("--camera-hz", type=v.number(RATE_HZ_RANGE[0], SIM_CONTROL_HZ), default=10.0,
                   help=f"video frame rate, Hz (default 10, at most {SIM_CONTROL_HZ:g}: one frame per control tick)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)


def list_tasks() -> str:
    import dataclasses

    from code_as_monitor.sim.tasks import TaskConfig, task_names

    lines = []
    for name in task_names():
        cls = TaskConfig.get_class(name)
        doc = (cls.task_class.__module__ and __import__(cls.task_class.__module__, fromlist=["x"]).__doc__) or ""
        first = doc.strip().splitlines()[0] if doc.strip() else ""
        lines.append(f"{name}: {first.split(':', 1)[-1].strip()}")
        for f in dataclasses.fields(cls):
            lines.append(f"    {f.name} = {f.default!r}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if args.list:
        print(list_tasks())
        return 0
    if not args.task:
        raise ConfigError("cam sim: give a task id (see `cam sim --list`)")
    import dataclasses

    import code_as_monitor.sim.tasks  # noqa: F401  (registers the tasks)
    from code_as_monitor.sim.cameras import camera_set
    from code_as_monitor.sim.episode import run_open_loop
    from code_as_monitor.sim.tasks.base import TaskConfig
    from code_as_monitor.sim.world import WorldConfig

    cfg = v.parse_settings(args.set)
    if args.p is not None:
        cfg["p"] = args.p
    if args.q is not None:
        cfg["q"] = args.q
    TaskConfig.from_name(args.task, **cfg)  # a bad task id or field is one line before anything is written
    events = args.events
    if events is None and args.video is not None:
        events = v.check_new_file(args.video.with_name(args.video.stem + ".events.jsonl"), "--events")
    if args.video is not None and args.video.suffix.lower() != ".mp4":
        raise ConfigError(f"--video {args.video}: the video is an MP4; give a path ending in .mp4")
    if events is not None and args.video is not None and events.absolute() == args.video.absolute():
        raise ConfigError(f"--events and --video are the same file {events}")
    wc = WorldConfig(renderer=args.renderer, camera_hz=args.camera_hz)
    wc = dataclasses.replace(wc, cameras=camera_set(args.cameras, wc.width, wc.height))
    res = run_open_loop(args.task, seed=args.seed, world_config=wc, video=args.video, events_path=events, **cfg)
    if args.json:
        print(json.dumps(res.to_dict()))
    else:
        kinds: dict[str, int] = {}
        for e in res.events:
            kinds[e["kind"]] = kinds.get(e["kind"], 0) + 1
        print(f"{res.task} seed={res.seed}: {'SUCCESS' if res.success else 'FAILURE'} ({res.reason}) "
              f"at t={res.t:.2f} s")
        print("events: " + ", ".join(f"{k}={v}" for k, v in sorted(kinds.items())))
        if args.video is not None:
            print(f"video: {args.video} ({res.n_frames} frames)")
        if events is not None:
            print(f"event log: {events}")
    return 0
