"""``cam demo``: the main job on the embedded offline default.

stack-in-order (red at the bottom, then green, then blue) with the paper's drop disturbance p = 0.3,
planned and coded by the kb backend (a rule-based stand-in for a VLM, not a VLM), painted from the
simulator's ground-truth masks and tracked in 3-D by the `depth` tracker (each object's points registered to
the depth images; no simulator pose). Prints a live log and writes
runs/<id>/ (episode.mp4, prompts/, programs/, events.jsonl, ground_truth.jsonl, summary.json).
Any option of `cam run` can be changed, e.g. `cam demo --tracker sim` or `cam demo --seed 4`.
"""

from __future__ import annotations

import argparse

from code_as_monitor.cli.run_cmd import add_common, config_from_args, execute

DEMO_TASK = "stack-in-order"
DEMO_SEED = 10
DEMO_PARAMS = {"p": 0.3}


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("demo", help="the main job: stack-in-order with drops (p=0.3), offline default",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_common(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    cfg = config_from_args(args, DEMO_TASK, default_seed=DEMO_SEED, default_params=DEMO_PARAMS)
    code = execute(args, cfg)
    return 0 if code in (0, 1) else code  # a failed episode is a result; an error or interrupt is not
