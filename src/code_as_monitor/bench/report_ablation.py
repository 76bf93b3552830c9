"""The ablation table from a results file of ``cam bench --suite ablation``, beside the paper's.

Per task (stow-book, slot-pen, pour-tea), one row per CaM setting (full, MV off, CS off, CP off, reactive only,
proactive only) and one column per disturbance setting (None, (a), (b), (c)): success % with its count, their
average over the four settings (as the paper averages), and the mean simulated execution time. Then the paper's
ablation table (stow-book) and its supplementary table of detection modes.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.bench.paper import PAPER_ABLATION, PAPER_MODES
from code_as_monitor.bench.protocol import CONDITIONS, SUITE_DEFAULTS
from code_as_monitor.bench.report_notes import cameras_note, planner_phrase, tracker_phrase

TASKS = ("stow-book", "slot-pen", "pour-tea")
ROW_NAMES = {
    "cam": "Full CaM",
    "cam-mv-off": "MV off (front view only)",
    "cam-cs-off": "CS off (ORB keypoints, k-means; not DINOv2)",
    "cam-cp-off": "CP off (unconnected points)",
    "cam-reactive-only": "reactive checks only",
    "cam-proactive-only": "proactive checks only",
}
PAPER_ROW_NAMES = {
    "cam": "Full CaM",
    "cam-mv-off": "MV off",
    "cam-cs-off": "CS off (DINOv2 points)",
    "cam-cp-off": "CP off",
    "cam-reactive-only": "reactive checks only",
    "cam-proactive-only": "proactive checks only",
}
"""Row names of the paper's tables: the paper's own settings (its CS off used DINOv2, not our ORB analogue)."""


def _conditions(task: str) -> list[str]:
    """The task's Table 2 condition ids in the order None, (a), (b), (c)."""
    return [c.id for c in CONDITIONS if c.suite == "table2" and c.task == task]


def _pct(rs: list[dict[str, Any]]) -> tuple[float, str]:
    ok = sum(1 for r in rs if r["success"])
    return 100.0 * ok / len(rs), f"{100.0 * ok / len(rs):.0f} ({ok}/{len(rs)})"


def ablation_rows(records: list[dict[str, Any]], task: str) -> list[dict[str, Any]]:
    """One dict per method present for ``task``: ``cells`` (per condition: (rate %, text) or None), ``avg`` (the
    mean of the four rates, None unless all four are present), ``time`` (mean sim seconds), ``n``, ``errors``."""
    conds = _conditions(task)
    out = []
    for m in SUITE_DEFAULTS["ablation"]["methods"]:
        rs_m = [r for r in records if r["method"] == m and r["condition"] in conds]
        if not rs_m:
            continue
        cells = []
        for c in conds:
            rs = [r for r in rs_m if r["condition"] == c]
            cells.append(_pct(rs) if rs else None)
        times = [float(r["sim_time_s"]) for r in rs_m if r.get("sim_time_s") is not None]
        avg = sum(c[0] for c in cells if c) / 4 if all(cells) else None
        out.append({"method": m, "cells": cells, "avg": avg, "time": sum(times) / len(times) if times else None,
                    "n": len(rs_m), "errors": sum(1 for r in rs_m if r.get("error"))})
    return out


def ablation_markdown(summary: dict[str, Any]) -> str:
    """Our tables per task, then the paper's (see the module docstring)."""
    recs, opts = summary["records"], summary.get("options") or {}
    out = [f"Perception: elements painted from `{opts.get('segmenter', 'sim')}` masks (CS off: ORB keypoints in the "
           f"`{opts.get('segmenter', 'sim')}` instance masks), tracked by {tracker_phrase(opts.get('tracker', 'sim'))}"
           + f"; planner and coder: {planner_phrase(opts.get('backend', 'kb'))}." + cameras_note(opts), "",
           "Success % (successes/runs) per disturbance setting; Avg: the mean of the four rates (as the paper's); "
           "time: mean simulated seconds per episode.", ""]
    for task in TASKS:
        rows = ablation_rows(recs, task)
        if not rows:
            continue
        out += [f"**{task}**", "", "| Setting | None | (a) | (b) | (c) | Avg | time s | errors |",
                "|---|---|---|---|---|---|---|---|"]
        for r in rows:
            cells = [c[1] if c else "—" for c in r["cells"]]
            avg = f"{r['avg']:.1f}" if r["avg"] is not None else "—"
            t = f"{r['time']:.1f}" if r["time"] is not None else "—"
            out.append(f"| {ROW_NAMES[r['method']]} | " + " | ".join(cells) + f" | {avg} | {t} | {r['errors']} |")
        out.append("")
    out += ["Paper, ablation table (OmniGibson, stow-book, 10 runs per setting; CS off used DINOv2 points):", "",
            "| Setting | None | (a) | (b) | (c) | Avg |", "|---|---|---|---|---|---|"]
    for m, v in PAPER_ABLATION.items():
        out.append(f"| {PAPER_ROW_NAMES[m]} | " + " | ".join(f"{x:.0f}" for x in v) + f" | {sum(v) / 4:.1f} |")
    out += ["", "Paper, supplementary table of detection modes (average success % under disturbance / time s):", "",
            "| Setting | " + " | ".join(TASKS) + " |", "|---|---|---|---|"]
    for m, per in PAPER_MODES.items():
        cells = " | ".join(f"{per[t][0]:.1f} / {per[t][1]:.1f} s" for t in TASKS)
        out.append(f"| {PAPER_ROW_NAMES[m]} | {cells} |")
    return "\n".join(out) + "\n"


__all__ = ["PAPER_ROW_NAMES", "ROW_NAMES", "TASKS", "ablation_markdown", "ablation_rows"]
