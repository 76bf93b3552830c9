"""``cam reproduce``: re-run one episode of a benchmark results file and compare it with its record.

    cam reproduce results/published/cliport.jsonl --key stack-p0.3/cam/0/3
    cam reproduce runs/bench/cliport.jsonl --key stack-q2/doremi/1/7 --video

KEY is CONDITION/METHOD/SEED/EPISODE, as every record's ``reproduce`` field writes it. The method options
come from the results file; the episode runs through the same code as ``cam bench``. Prints the recorded and
the re-run outcome, alarms and ground-truth failures, and what differs. CaM records also carry ``run``, the
equivalent ``cam run`` command (live log, run directory).

Exit codes: 0 the re-run matches its record; 1 it differs; 2 a bad argument, file or key.
"""

from __future__ import annotations

import argparse

from code_as_monitor.cli import validate as v


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("reproduce", help="re-run one benchmark record and compare it with the record",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results", type=v.input_file, help="JSONL results file written by cam bench")
    p.add_argument("--key", required=True, help="CONDITION/METHOD/SEED/EPISODE of the record")
    p.add_argument("--video", action="store_true", help="write the re-run's episode.mp4 into a fresh run dir")
    p.add_argument("--runs", type=v.output_dir, default="runs", help="parent of the run dir (default runs/)")
    p.set_defaults(func=run)


def _show(label: str, r: dict) -> None:
    print(f"{label}: success={r.get('success')} ({r.get('reason')}), sim time {r.get('sim_time_s')} s")
    for a in r.get("alarms") or []:
        print(f"  alarm t={float(a['t']):7.3f}  {a['constraint_id']}")


def run(args: argparse.Namespace) -> int:
    from code_as_monitor.bench.reproduce import find_record, parse_key, reproduce
    from code_as_monitor.core.run_io import new_run_dir

    parse_key(args.key)
    _, rec = find_record(args.results, args.key)  # a missing key is one line before anything runs
    if rec.get("run"):
        print(f"equivalent: {rec['run']}")
    video_dir = new_run_dir(args.runs, prefix="reproduce") if args.video else None
    res = reproduce(args.results, args.key, video_dir)
    _show("recorded", res.record)
    _show("re-run  ", res.rerun)
    if res.same:
        print("the re-run matches its record")
        return 0
    print("differences:")
    for d in res.differences:
        print(f"  - {d}")
    return 1
