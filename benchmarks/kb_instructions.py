"""The kb planner on the instruction table: plans right, refused, wrong (planner: the kb stand-in, not a VLM).

Reads the table of ``tests/vlm/instruction_table.py`` (instructions across the seven task families with the
plan each must produce, or a refusal) and the generated phrasings of ``tests/vlm/test_vlm_instruction_table.py``
(every tower order x 20 phrasings, counts and fractions for sweeping, impossible requests), plans each with
the kb (feeding "success" after every subgoal) and counts:

- right: the expected plan, or a refusal where one is expected;
- refused: a plannable instruction the kb refused (allowed, counted);
- wrong: any other plan, or a plan for an instruction that must be refused (the bar is zero).

Also the median time to read and plan one instruction, against the median time of parsing it alone (a
reference measured in the same run). No perception is involved.

    .venv/bin/python benchmarks/kb_instructions.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import time
from pathlib import Path

TESTS = Path(__file__).resolve().parent.parent / "tests" / "vlm"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5, help="timing passes over the table (default 5)")
    args = ap.parse_args()
    sys.path.insert(0, str(TESTS))
    from instruction_table import SCENES, TABLE, counts, plan_of
    from test_vlm_instruction_table import GENERATED

    from code_as_monitor.core.errors import InstructionError
    from code_as_monitor.vlm.grammar import parse

    for name, rows in (("table", TABLE), ("generated", GENERATED)):
        total, misses = counts(rows)
        print(f"{name}: {len(rows)} instructions (planner: kb stand-in)")
        for verdict, instruction, detail in misses:
            print(f"  {verdict}: {instruction!r}: {detail[:140]}")
        for key in ("right", "refused", "wrong"):
            print(f"{name}_{key}: {total[key]} instructions")

    def plan_all() -> None:
        for scene, instruction, _ in TABLE:
            with contextlib.suppress(InstructionError):
                plan_of(instruction, SCENES[scene])

    def parse_all() -> None:
        for _, instruction, _ in TABLE:
            parse(instruction)

    plans, parses = [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        plan_all()
        plans.append((time.perf_counter() - t0) / len(TABLE))
        t0 = time.perf_counter()
        parse_all()
        parses.append((time.perf_counter() - t0) / len(TABLE))
    plan_ms, parse_ms = statistics.median(plans) * 1e3, statistics.median(parses) * 1e3
    print(f"plan_per_instruction_median: {plan_ms:.3f} ms")
    print(f"parse_per_instruction_median: {parse_ms:.3f} ms")
    print(f"plan_over_parse_ratio: {plan_ms / parse_ms:.1f} x")


if __name__ == "__main__":
    main()
