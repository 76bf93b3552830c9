"""``cam report``: Markdown table (paper layout) + self-contained HTML from a benchmark results file.

    cam report results/cliport.jsonl                   # writes results/cliport-report/report.{md,html}
    cam report results/cliport.jsonl --out out/ --print
"""

from __future__ import annotations

import argparse
from pathlib import Path

from code_as_monitor.core.errors import RunError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("report", help="tables, plots and video links from a `cam bench` results file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", type=Path, help="JSONL results file written by cam bench")
    p.add_argument("--out", type=Path, default=None, help="output directory (default <results stem>-report/)")
    p.add_argument("--print", action="store_true", help="also print the Markdown to stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from code_as_monitor.bench.report import write_report

    if not args.results.exists():
        raise RunError(f"no results file {args.results}")
    out = args.out or args.results.with_name(args.results.stem + "-report")
    md, page = write_report(args.results, out)
    if args.print:
        print(md.read_text(encoding="utf-8"))
    print(f"wrote {md} and {page}")
    return 0
