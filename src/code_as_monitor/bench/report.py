"""Reports from a results file: a Markdown table in the paper's layout and a self-contained HTML page.

Rows are conditions, columns methods (CLIPort alone = ``open-loop``, +Inner Monologue, +DoReMi,
+Ours = ``cam``), success rate and execution time as mean +- 95 % CI (see ``bench.metrics``), then
VLM cost and our detection metrics. The HTML embeds its plots (PNG, base64): success rate and time
per condition with error bars, and the detection latency distribution; and links every cell's sample
video (relative to the page).
"""

from __future__ import annotations

import base64
import html
import io
import math
import os
from pathlib import Path
from typing import Any

from code_as_monitor.bench.metrics import cell_summary
from code_as_monitor.bench.paper import PAPER
from code_as_monitor.bench.protocol import CONDITIONS, METHODS
from code_as_monitor.bench.runner import episode_records, read_results

HEADERS = {"open-loop": "CLIPort (open-loop)", "inner-monologue": "+Inner Monologue", "doremi": "+DoReMi",
           "cam": "+Ours (CaM)"}
STANDIN_NOTE = ("Offline (backend `kb`), Inner Monologue's and DoReMi's VQA answers come from `vqa-standin`, "
                "a rule-based single-image stand-in (colour blobs, 2-D image heuristics), not a VLM; the "
                "planner of every method is the `kb` knowledge base, also a rule-based stand-in.")


def _f(x: float, digits: int = 1) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def _pm(s: dict[str, Any], digits: int = 1) -> str:
    if s is None or math.isnan(s["mean"]):
        return "—"
    return f"{s['mean']:.{digits}f} ± {_f(s['ci'], digits)}"


def summarise(path: str | Path) -> dict[str, Any]:
    """Cells, sessions and wall time of a results file."""
    lines = read_results(path)
    recs = episode_records(lines)
    cells: dict[tuple[str, str], dict[str, Any]] = {}
    present_c = [c for c in CONDITIONS if any(r["condition"] == c.id for r in recs)]
    present_m = [m for m in METHODS if any(r["method"] == m for r in recs)]
    for c in present_c:
        for m in present_m:
            rs = [r for r in recs if r["condition"] == c.id and r["method"] == m]
            if rs:
                cells[(c.id, m)] = {**cell_summary(rs, c.undisturbed),
                                    "video": next((r["video"] for r in rs if r.get("video")), None)}
    return {"conditions": present_c, "methods": present_m, "cells": cells, "records": recs,
            "wall_s": wall_time(lines), "options": next((r["options"] for r in lines if r.get("kind") == "bench_start"),
                                                        {})}


def wall_time(lines: list[dict[str, Any]]) -> float:
    """Total wall seconds over sessions: each from its ``bench_start`` to its last finished episode."""
    total, start, last = 0.0, None, None
    for r in lines:
        if r.get("kind") == "bench_start":
            if start is not None and last is not None:
                total += last - start
            start, last = r.get("epoch"), None
        elif r.get("kind") == "episode" and r.get("finished_at") is not None:
            last = r["finished_at"]
    if start is not None and last is not None:
        total += last - start
    return total


def markdown(summary: dict[str, Any], with_paper: bool = True) -> str:
    """The Markdown tables (ours; the paper's beside it; cost; detection)."""
    ms, cs, cells = summary["methods"], summary["conditions"], summary["cells"]
    opts = summary.get("options") or {}
    tracker = opts.get("tracker", "sim")
    out = [f"CaM perception: elements painted from `{opts.get('segmenter', 'sim')}` masks, tracked by `{tracker}`"
           + (" (the oracle: ground-truth poses)" if tracker == "sim" else " (no simulator poses)") + ".", "",
           "| Condition | n/cell | " + " | ".join(f"SR {HEADERS[m]}" for m in ms) + " | "
           + " | ".join(f"Time {HEADERS[m]}" for m in ms if m != "open-loop") + " |",
           "|---|---|" + "---|" * (len(ms) + len([m for m in ms if m != "open-loop"]))]
    for c in cs:
        row = [c.label, str(min((cells[(c.id, m)]["n"] for m in ms if (c.id, m) in cells), default=0))]
        row += [_pm(cells[(c.id, m)]["success"]) if (c.id, m) in cells else "—" for m in ms]
        row += [_pm(cells[(c.id, m)]["time"]) if (c.id, m) in cells else "—" for m in ms if m != "open-loop"]
        out.append("| " + " | ".join(row) + " |")
    if with_paper:
        caption = ("Paper (Table 2, OmniGibson, 10 runs per setting; open-loop = ReKep alone; time per task):"
                   if cs and all(c.suite == "table2" for c in cs)
                   else "Paper (supplementary table, 5 seeds x 12 episodes):")
        out += ["", caption, "",
                "| Condition | " + " | ".join(f"SR {HEADERS[m]}" for m in METHODS) + " | "
                + " | ".join(f"Time {HEADERS[m]}" for m in METHODS[1:]) + " |",
                "|---|" + "---|" * (2 * len(METHODS) - 1)]
        for c in cs:
            p = PAPER.get(c.id, {})
            row = [c.label] + [f"{p[m][0]:.2f} ± {p[m][1]:.2f}" if m in p else "—" for m in METHODS]
            row += [f"{p[m][2]:.2f} ± {p[m][3]:.2f}" if m in p and p[m][2] is not None else "—" for m in METHODS[1:]]
            out.append("| " + " | ".join(row) + " |")
    out += ["", "VLM calls / tokens per episode, wall seconds per episode:", "",
            "| Condition | " + " | ".join(HEADERS[m] for m in ms) + " |", "|---|" + "---|" * len(ms)]
    for c in cs:
        row = [c.label]
        for m in ms:
            k = cells.get((c.id, m))
            row.append("—" if k is None else f"{_f(k['cost']['calls'])} / {_f(k['cost']['tokens'], 0)} / "
                       f"{_f(k['cost']['wall_s'])} s")
        out.append("| " + " | ".join(row) + " |")
    out += ["", "Detection (ours, against the simulator's ground truth): recall (detected/failures), median "
            "latency s, unmatched alarms per episode, proactive precision (confirmed/rollouts), median lead s:", "",
            "| Condition | " + " | ".join(HEADERS[m] for m in ms if m != "open-loop") + " |",
            "|---|" + "---|" * len([m for m in ms if m != "open-loop"])]
    for c in cs:
        row = [c.label]
        for m in ms:
            if m == "open-loop":
                continue
            k = cells.get((c.id, m))
            if k is None:
                row.append("—")
                continue
            d = k["detection"]
            rec = f"{_f(d['recall'] * 100, 0)}% ({d['detected']}/{d['failures']})" if d["failures"] else "—"
            pro = (f"{_f(d['proactive_precision'] * 100, 0)}% ({d['proactive_confirmed']}/{d['proactive_alarms']})"
                   if d["proactive_alarms"] else "—")
            row.append(f"R {rec}; lat {_f(d['latency_median'], 2)}; FA {_f(d['unmatched_per_ep'], 2)}; "
                       f"P {pro}; lead {_f(d['lead_median'], 1)}")
        out.append("| " + " | ".join(row) + " |")
    errs = sum(k["errors"] for k in cells.values())
    out += ["", f"Episodes: {len(summary['records'])}, errors: {errs}; wall time of the sessions: "
            f"{summary['wall_s'] / 60:.1f} min.", "", STANDIN_NOTE]
    return "\n".join(out) + "\n"


def _png(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    return base64.b64encode(buf.getvalue()).decode()


def plots(summary: dict[str, Any]) -> dict[str, str]:
    """base64 PNGs: success rate and time per condition with error bars; latency distribution."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    ms, cs, cells = summary["methods"], summary["conditions"], summary["cells"]
    out = {}
    x = np.arange(len(cs))
    w = 0.8 / max(len(ms), 1)
    for key, title in (("success", "Success rate (%)"), ("time", "Execution time (sim s)")):
        fig, ax = plt.subplots(figsize=(10, 3.4))
        for i, m in enumerate(ms):
            mean = [cells[(c.id, m)][key]["mean"] if (c.id, m) in cells else np.nan for c in cs]
            ci = [cells[(c.id, m)][key]["ci"] if (c.id, m) in cells else np.nan for c in cs]
            ax.bar(x + (i - (len(ms) - 1) / 2) * w, mean, w, yerr=np.nan_to_num(ci), capsize=2, label=HEADERS[m])
        ax.set_xticks(x, [c.id for c in cs], rotation=20)
        ax.set_title(title)
        ax.legend(fontsize=7, ncol=len(ms))
        out[key] = _png(fig)
        plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 3.2))
    for m in ms:
        lat = [v for (c, mm), k in cells.items() if mm == m for v in k["detection"]["latencies"]]
        if lat:
            ax.hist(lat, bins=np.arange(-0.25, 5.25, 0.25), alpha=0.5, label=f"{HEADERS[m]} (n={len(lat)})")
    ax.set_xlabel("detection latency (s, alarm - ground-truth failure)")
    ax.set_ylabel("failures")
    ax.legend(fontsize=7)
    out["latency"] = _png(fig)
    plt.close(fig)
    return out


def write_report(results: str | Path, out_dir: str | Path) -> tuple[Path, Path]:
    """Write ``report.md`` and ``report.html`` (self-contained) into ``out_dir``; returns their paths."""
    import markdown_it

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    s = summarise(results)
    title = "Table 2 benchmark" if s["conditions"] and all(c.suite == "table2" for c in s["conditions"]) \
        else "CLIPort benchmark"
    md = f"# {title}\n\nResults: `{results}`\n\n" + markdown(s)
    (out / "report.md").write_text(md, encoding="utf-8")
    imgs = plots(s) if s["cells"] else {}
    videos = []
    for (cid, m), k in sorted(s["cells"].items()):
        if k.get("video"):
            rel = os.path.relpath(Path(k["video"]).resolve(), out.resolve())
            videos.append(f'<li>{html.escape(cid)} / {html.escape(HEADERS[m])}: '
                          f'<a href="{html.escape(rel)}">{html.escape(rel)}</a></li>')
    body = markdown_it.MarkdownIt("commonmark").enable("table").render(md)
    figs = "".join(f'<h2>{t}</h2><img alt="{t}" src="data:image/png;base64,{imgs[k]}"/>'
                   for k, t in (("success", "Success rate"), ("time", "Execution time"),
                                ("latency", "Detection latency")) if k in imgs)
    page = (f"<!doctype html><html><head><meta charset='utf-8'><title>CaM CLIPort benchmark</title>"
            "<style>body{font-family:sans-serif;max-width:1200px;margin:auto}table{border-collapse:collapse;"
            "font-size:12px}td,th{border:1px solid #ccc;padding:3px 6px}</style></head><body>"
            f"{body}{figs}<h2>Sample videos</h2><ul>{''.join(videos) or '<li>none recorded</li>'}</ul></body></html>")
    (out / "report.html").write_text(page, encoding="utf-8")
    return out / "report.md", out / "report.html"


__all__ = ["HEADERS", "STANDIN_NOTE", "markdown", "plots", "summarise", "wall_time", "write_report"]
