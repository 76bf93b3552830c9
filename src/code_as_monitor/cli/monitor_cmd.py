"""``cam monitor``: replay a recorded RGB-D bag through planner, painter, tracker and monitor.

    cam monitor ep.mcap                                   # a `cam record` bag: instruction from the bag
    cam monitor rs.mcap --instruction "stack the blocks" --objects red_block,green_block,blue_block
    cam monitor rs_bag/ --topics my_robot.yaml --rate realtime --segmenter color

Reads MCAP or sqlite3 bags with rosbags (no ROS install). Without --topics: the topic map a
`cam record` bag carries, else the RealSense ROS 2 driver's names (/camera/camera/color/image_raw,
/camera/camera/aligned_depth_to_color/image_raw (16UC1 mm), /camera/camera/color/camera_info, TF in
/tf_static). Streams are matched by header stamps (nearest within the map's sync_tolerance_s);
frames dropped for sync are counted and reported. Writes a fresh runs/<id>/ (events.jsonl,
episode.mp4 with the elements and verdicts, prompts/, programs/, summary.json).

Exit codes: 0 replayed, 2 bad input (unreadable / truncated / corrupt bag, missing topic, colour and
depth sizes differ, unknown encoding, bad topic map or option; no run dir is made), 3 error during
the replay (summary.json says it), 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from code_as_monitor.cli import validate as v
from code_as_monitor.cli.run_cmd import EXIT_CODES, add_monitor_options, backend_options_from_args
from code_as_monitor.core.errors import ConfigError

MONITOR_EXIT = {**EXIT_CODES, "completed": 0}


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("monitor", help="replay a ROS 2 bag (MCAP / sqlite3) through the monitor",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", type=v.input_path, help="bag: a .mcap or .db3 file or a rosbag2 directory")
    p.add_argument("--instruction", default=None, help="the task instruction (default: the bag's, if recorded)")
    p.add_argument("--topics", type=v.input_file, default=None, help="topic map YAML (see docs/robot.md)")
    p.add_argument("--objects", default=None, help="comma-separated scene object names (default: the map's)")
    p.add_argument("--rate", default="max", choices=("max", "realtime"),
                   help="hand frames over as fast as possible (default) or at the recorded pace")
    add_monitor_options(p, segmenter="auto")
    p.set_defaults(func=run)


def prepare(args: argparse.Namespace) -> tuple[Any, Any, str, Any]:
    """Open and check the bag and the monitor's configuration; nothing is written."""
    from code_as_monitor.agent.config import MonitorConfig
    from code_as_monitor.core.extras import require
    from code_as_monitor.recordings.reader import BagSource
    from code_as_monitor.recordings.topics import TopicMap
    from code_as_monitor.vlm import VLMBackendConfig, make_backend

    require("rosbags", "ros")
    topics = TopicMap.load(args.topics) if args.topics is not None else None
    if args.instruction is not None and not args.instruction.strip():
        raise ConfigError("--instruction is empty")
    objects = [o.strip() for o in args.objects.split(",") if o.strip()] if args.objects is not None else None
    if objects == []:
        raise ConfigError(f"--objects expects comma-separated object names, got {args.objects!r}")
    source = BagSource(args.bag, topics=topics, objects=objects)
    instruction = args.instruction or source.metadata.get("instruction")
    if not instruction:
        raise ConfigError(f"{args.bag} records no instruction: pass --instruction \"...\"")
    segmenter = args.segmenter
    if segmenter == "auto":
        segmenter = "sim" if all(v.seg for v in source.map.views.values()) else "color"
    cfg = MonitorConfig(backend=args.backend, backend_options=backend_options_from_args(args), segmenter=segmenter,
                        tracker=args.tracker, frame_hz=args.camera_hz, max_replans=args.max_replans,
                        deadline_s=args.deadline, time_limit_s=source.metadata.get("time_limit_s"),
                        allow_unconfined=args.allow_unconfined)
    cfg.check()
    backend = make_backend(VLMBackendConfig.from_name(cfg.backend, **cfg.backend_options))
    return source, cfg, instruction, backend


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from code_as_monitor.bench.closed_loop import early_end
    from code_as_monitor.bench.replay import replay_bag
    from code_as_monitor.cli.live_log import LiveLog
    from code_as_monitor.cli.run_cmd import chain_events, check_extras, extra_hooks
    from code_as_monitor.cli.signals import sigterm_as_interrupt
    from code_as_monitor.core.run_io import new_run_dir

    check_extras(args)
    source, cfg, instruction, backend = prepare(args)
    console = Console(highlight=False)
    run_dir = new_run_dir(args.runs, prefix=f"monitor-{args.bag.stem or 'bag'}")
    st = source.stats
    console.print(f"[dim]{args.bag}: {st.frames} synchronised frames over {source.duration_s:.1f} s "
                  f"({st.dropped_total} of {st.color_frames} colour frames dropped for sync); segmenter "
                  f"{cfg.segmenter}, tracker {cfg.tracker}; writing {run_dir}/[/]")
    log = LiveLog(console, verbose=args.verbose > 0)
    hooks = extra_hooks(args, run_dir)
    try:
        with sigterm_as_interrupt():
            summary = replay_bag(source, instruction, cfg, run_dir, rate=args.rate, video=not args.no_video,
                                 backend=backend, on_event=chain_events(None if args.quiet else log, hooks),
                                 frame_hooks=hooks.frame_hooks)
    except BaseException as exc:
        outcome, reason = early_end(exc)
        print(f"cam monitor: {outcome}: {reason} (summary in {run_dir}/summary.json)", file=sys.stderr)
        return MONITOR_EXIT[outcome]
    finally:
        hooks.close()
    ep = summary["episode"]
    console.print(f"replayed {summary['frames']['judged']} frames in {summary['wall_time_s']:.1f} s "
                  f"({summary['replay_realtime_factor']}x real time): {len(ep['alarms'])} alarms, "
                  f"{ep['replans']} re-plans, {ep['stop_reason']}; dropped for sync: {summary['frames']['dropped']}")
    if summary["outcome"] == "error":
        print(f"cam monitor: error: {summary['error']}", file=sys.stderr)
    return MONITOR_EXIT[summary["outcome"]]
