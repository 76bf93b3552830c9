"""``cam record``: run a closed-loop simulator episode and write it as a ROS 2 bag.

    cam record stack-in-order --seed 3 --p 0.3 --out ep.mcap
    cam record slot-pen --seed 1 --out pen.db3 --depth-encoding 16UC1

The bag (OUT ending .mcap: one MCAP file; .db3: one sqlite3 file; else a rosbag2 directory) holds
every frame the monitor took as standard messages (sensor_msgs/Image colour, depth and ground-truth
segmentation, CameraInfo, /tf with the end effector and ground-truth object poses, /tf_static with
the cameras, JointState), the policy's state and the simulator's ground-truth events on side topics
(/cam/policy_state, /cam/ground_truth, /cam/metadata). The live run's directory is written as by
`cam run`; `cam monitor OUT` replays the bag and should raise the same alarms.

Exit codes: 0 the bag was written, 2 bad input (nothing written), 3 error, 130 interrupted (no bag
is left behind: it is moved into place only when complete).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from code_as_monitor.cli import validate as v
from code_as_monitor.cli.run_cmd import EXIT_CODES, add_common, config_from_args
from code_as_monitor.core.errors import ConfigError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("record", help="record a simulator episode as a ROS 2 bag (MCAP or sqlite3)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("task", help="simulator task id (see `cam sim --list`)")
    p.add_argument("--out", type=v.new_file, required=True, help="output bag: X.mcap, X.db3 or a directory name")
    p.add_argument("--depth-encoding", default="32FC1", choices=("32FC1", "16UC1"),
                   help="depth as 32FC1 metres (exact, default) or 16UC1 millimetres (as a RealSense)")
    add_common(p)
    p.set_defaults(func=run, size="320x240")


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from code_as_monitor.bench.closed_loop import early_end, make_checked_backend
    from code_as_monitor.bench.record import record_episode
    from code_as_monitor.cli.live_log import LiveLog
    from code_as_monitor.cli.signals import sigterm_as_interrupt
    from code_as_monitor.core.extras import require
    from code_as_monitor.core.run_io import new_run_dir

    require("rosbags", "ros")
    if args.rerun or args.rerun_url:
        raise ConfigError("--rerun applies to cam run, cam demo and cam monitor")
    cfg = config_from_args(args, args.task)
    out: Path = args.out
    if out.exists():
        raise ConfigError(f"--out {out} exists already; a recording is never overwritten")
    if not out.parent.is_dir():
        raise ConfigError(f"--out {out}: directory {out.parent} does not exist")
    backend = make_checked_backend(cfg)
    console = Console(highlight=False)
    run_dir = new_run_dir(args.runs, prefix=f"record-{cfg.task}-s{cfg.seed}")
    console.print(f"[dim]recording {cfg.task} seed {cfg.seed} ({cfg.width}x{cfg.height} at {cfg.camera_hz:g} Hz) "
                  f"to {out}; live run in {run_dir}/[/]")
    log = LiveLog(console, verbose=args.verbose > 0)
    try:
        with sigterm_as_interrupt():
            summary = record_episode(cfg, out, run_dir, depth_encoding=args.depth_encoding, backend=backend,
                                     on_event=None if args.quiet else log)
    except BaseException as exc:
        outcome, reason = early_end(exc)
        print(f"cam record: {outcome}: {reason}; no bag written (summary in {run_dir}/summary.json)",
              file=sys.stderr)
        return EXIT_CODES[outcome]
    bag = summary["bag"]
    console.print(f"wrote {bag['path']}: {bag['frames']} frames, {len(summary['episode']['alarms'])} alarms in the "
                  f"live run, task {'succeeded' if summary['success'] else 'failed'}")
    return 3 if summary["outcome"] == "error" else 0
