"""The ``cam`` command. Thin: each subcommand parses arguments and calls one library function.

Subcommands live in their own modules under ``code_as_monitor.cli`` and expose
``add_parser(subparsers) -> None`` and ``run(args) -> int``. Modules must import heavy libraries
inside ``run`` so that ``cam --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence

from code_as_monitor import __version__
from code_as_monitor.core.errors import CamError

# Order shown in `cam --help`. A module that does not exist yet is skipped.
COMMAND_MODULES: tuple[str, ...] = (
    "demo_cmd",
    "run_cmd",
    "record_cmd",
    "monitor_cmd",
    "elements_cmd",
    "sim_cmd",
    "plan_cmd",
    "bench_cmd",
    "report_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cam",
        description=(
            "Code-as-Monitor: constraint-aware visual programming for reactive and proactive robotic "
            "failure detection. Runs offline by default (knowledge-base planner, simulator "
            "segmentation, OpenCV tracking)."
        ),
    )
    parser.add_argument("--version", action="version", version=f"cam {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            mod = importlib.import_module(f"code_as_monitor.cli.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"code_as_monitor.cli.{name}":
                continue
            raise
        mod.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = {0: logging.WARNING, 1: logging.INFO}.get(args.verbose, logging.DEBUG)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    if not getattr(args, "command", None):
        parser.print_help()
        return 0
    try:
        return int(args.func(args) or 0)
    except CamError as exc:
        print(f"cam {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"cam {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
