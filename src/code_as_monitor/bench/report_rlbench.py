"""The RLBench table from a results file of ``cam bench --suite rlbench`` (the restart protocol).

Rows are methods (the noisy scripted policy alone, our analogue of the paper's ARP; +DoReMi; +CaM), columns the
tasks and their average, as in the paper's table; then the paper's numbers, the restarts and time each valid
episode cost, and detection against the ground-truth ``policy_failure`` events (see ``bench.restarts`` for the
protocol and ``bench.metrics`` for the detection rules).
"""

from __future__ import annotations

import math
from typing import Any

from code_as_monitor.bench.paper import PAPER_RLBENCH, PAPER_RLBENCH_AVG
from code_as_monitor.bench.protocol import CONDITIONS, SUITE_DEFAULTS
from code_as_monitor.bench.restarts import attempts_by_cell, restart_summary

HEADERS = {"open-loop": "Scripted policy + action noise (ARP analogue)", "doremi": "+DoReMi",
           "cam": "+Ours (CaM)", "inner-monologue": "+Inner Monologue"}
METHOD_ORDER = ("open-loop", "inner-monologue", "doremi", "cam")


def _f(x: float, digits: int = 1) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def n_valid_of(records: list[dict[str, Any]]) -> tuple[int, str]:
    """Valid episodes per cell the run asked for: the open loop's attempts (it flags nothing, so it runs exactly
    that many); without open-loop records, the suite's default. Returns (n, how it was found)."""
    ol = [len(v) for (c, m, s), v in attempts_by_cell(records).items() if m == "open-loop"]
    if ol:
        return min(ol), "the open loop's episodes per cell"
    return int(SUITE_DEFAULTS["rlbench"]["episodes"]), "the suite's default"


def rlbench_markdown(records: list[dict[str, Any]]) -> str:
    """Markdown tables for the rlbench conditions in ``records``."""
    n, how = n_valid_of(records)
    summ = restart_summary(records, n)
    conds = [c for c in CONDITIONS if c.suite == "rlbench" and any(k[0] == c.id for k in summ)]
    methods = [m for m in METHOD_ORDER if any(k[1] == m for k in summ)]

    def cell(c: str, m: str) -> dict[str, Any] | None:
        return summ.get((c, m, 0))

    out = [f"Success over valid episodes (%; {n} valid episodes per cell wanted, from {how}; ± half-width of the "
           "95 % t-interval over episodes; `n` valid episodes reached, * short of the target at the attempt "
           "bound). A flagged episode is abandoned and another started (the paper's protocol).", "",
           "| Method | Avg | " + " | ".join(c.label for c in conds) + " |", "|---|---|" + "---|" * len(conds)]
    for m in methods:
        means, row = [], []
        for c in conds:
            k = cell(c.id, m)
            if k is None or not k["valid"]:
                row.append("—")
                continue
            s = k["success"]
            means.append(s["mean"])
            row.append(f"{_f(s['mean'])} ± {_f(s['ci'])} (n {k['valid']}{'' if k['complete'] else '*'})")
        avg = _f(sum(means) / len(means)) if len(means) == len(conds) and means else "—"
        out.append(f"| {HEADERS[m]} | {avg} | " + " | ".join(row) + " |")
    out += ["", "Paper (supplementary table \"Performance in RLBench\", 1000 valid episodes per task):", "",
            "| Method | Avg | " + " | ".join(c.label for c in conds) + " |", "|---|---|" + "---|" * len(conds)]
    for m, name in (("rvt2", "RVT2"), ("open-loop", "ARP"), ("doremi", "ARP +DRM (DoReMi)"), ("cam", "ARP +Ours")):
        out.append(f"| {name} | {PAPER_RLBENCH_AVG[m]:.2f} | "
                   + " | ".join(f"{PAPER_RLBENCH[c.id][m]:.1f}" for c in conds) + " |")
    out += ["", "Restarts and cost per valid episode: attempts used (restarts), sim seconds and wall seconds spent "
            "per valid episode, flagged attempts included:", "",
            "| Method | " + " | ".join(c.label for c in conds) + " |", "|---|" + "---|" * len(conds)]
    for m in methods:
        row = []
        for c in conds:
            k = cell(c.id, m)
            row.append("—" if k is None else f"{k['attempts']} ({k['restarts']}); {_f(k['sim_s_per_valid'])} s; "
                       f"{_f(k['wall_s_per_valid'])} s")
        out.append(f"| {HEADERS[m]} | " + " | ".join(row) + " |")
    checking = [m for m in methods if m != "open-loop"]
    if checking:
        out += ["", "Detection over every attempt used, against the ground-truth `policy_failure` events (the "
                "policy's first failed skill): recall (detected/failures), median latency s, false flags (an alarm "
                "that matches no failure and no counterfactual confirms) / flags:", "",
                "| Method | " + " | ".join(c.label for c in conds) + " |", "|---|" + "---|" * len(conds)]
        for m in checking:
            row = []
            for c in conds:
                k = cell(c.id, m)
                if k is None:
                    row.append("—")
                    continue
                d = k["detection"]
                false = round(d["unmatched_per_ep"] * d["episodes"]) if d["episodes"] else 0
                rec = f"{_f(d['recall'] * 100, 0)}% ({d['detected']}/{d['failures']})" if d["failures"] else "— (0/0)"
                row.append(f"R {rec}; lat {_f(d['latency_median'], 2)}; FA {false}/{d['alarms']}")
            out.append(f"| {HEADERS[m]} | " + " | ".join(row) + " |")
    fails = [r for r in records if r.get("error")]
    out += ["", f"Attempts in the file: {len(records)} ({len(fails)} errored, run again on resume)."]
    return "\n".join(out) + "\n"


__all__ = ["HEADERS", "n_valid_of", "rlbench_markdown"]
