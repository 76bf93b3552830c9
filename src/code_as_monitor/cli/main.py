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
import warnings
from collections.abc import Sequence

from code_as_monitor import __version__
from code_as_monitor.cli.validate import CamArgumentParser, check_namespace
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
    "reproduce_cmd",
)


def build_parser() -> argparse.ArgumentParser:
    parser = CamArgumentParser(
        prog="cam",
        description=(
            "Code-as-Monitor: constraint-aware visual programming for reactive and proactive robotic "
            "failure detection. Runs offline by default: the knowledge-base planner and coder (a rule-based "
            "stand-in for a VLM), simulator segmentation masks, and the depth tracker (each object's points "
            "registered to the depth images; no simulator pose)."
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


def quiet_third_party(verbose: int) -> None:
    """Keep other libraries' chatter out of our output unless ``-v`` asks for it: Python warnings
    (deprecations and the like) and the INFO/WARNING log lines of libraries that log on their own
    (Ray's token-authentication notice, for one). Our own log warnings still print."""
    if verbose:
        return
    warnings.filterwarnings("ignore")
    for name in ("ray", "matplotlib", "PIL", "httpx", "openai", "urllib3", "numba"):
        logging.getLogger(name).setLevel(logging.ERROR)


def main(argv: Sequence[str] | None = None) -> int:
    """Parse, validate and run one command; returns the exit status.

    0 done; 1 the command ran and reports a failure (``cam run``: the task failed); 2 a bad argument,
    path or file (one line on stderr, nothing created); 130 interrupted.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # a bad argument (already printed as one line) is an exit status, not an exit
        if exc.code == 2:
            return 2
        raise
    level = {0: logging.WARNING, 1: logging.INFO}.get(args.verbose, logging.DEBUG)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    quiet_third_party(args.verbose)
    if not getattr(args, "command", None):
        parser.print_help()
        return 0
    try:
        check_namespace(args)
        return int(args.func(args) or 0)
    except CamError as exc:
        print(f"cam {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:  # a path the checks could not foresee (a disk that filled up, a file that vanished)
        where = f" {exc.filename}" if exc.filename else ""
        print(f"cam {args.command}: error:{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"cam {args.command}: interrupted", file=sys.stderr)
        return 130


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


if __name__ == "__main__":
    sys.exit(main())
