"""``cam report``: Markdown table (paper layout) + self-contained HTML from a benchmark results file.

    cam report runs/bench/cliport-quick.jsonl          # writes runs/bench/cliport-quick-report/report.{md,html}
    cam report results/published/cliport.jsonl --out out/ --print

Success rate and time are mean ± the half-width of the 95 % t-interval over seeds (over episodes when
a cell has a single seed); an interval reaching past 0-100 % (or below 0 s) is shown clipped, marked †.
The report names the code versions of its records and says when it mixes several.
"""

from __future__ import annotations

import argparse

from code_as_monitor.cli import validate as v


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("report", help="tables, plots and video links from a `cam bench` results file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", type=v.input_file, help="JSONL results file written by cam bench")
    p.add_argument("--out", type=v.output_dir, default=None, help="output directory (default <results stem>-report/)")
    p.add_argument("--print", action="store_true", help="also print the Markdown to stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from code_as_monitor.bench.report import write_report

    out = args.out or v.check_output_dir(args.results.with_name(args.results.stem + "-report"), "--out")
    md, page = write_report(args.results, out)
    if args.print:
        print(md.read_text(encoding="utf-8"))
    print(f"wrote {md} and {page}")
    return 0
