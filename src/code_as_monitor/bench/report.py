"""Reports from a results file: a Markdown table in the paper's layout and a self-contained HTML page.

Rows are conditions, columns methods (CLIPort alone = ``open-loop``, +Inner Monologue, +DoReMi,
+Ours = ``cam``), success rate and execution time as mean +- the half-width of the 95 % t-interval
over seeds (over episodes when a cell has one seed; see ``bench.metrics``), then VLM cost and our
detection metrics. An interval that reaches past what the quantity can take (a success rate below
0 % or above 100 %, a negative time) is shown clipped, as its bounds ``mean (lo–hi)†``, and the
report says so. The report names the code versions its records come from and says when it mixes
several. The HTML embeds its plots (PNG, base64): success rate and time
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

from code_as_monitor.bench.metrics import cell_summary, detection
from code_as_monitor.bench.paper import PAPER
from code_as_monitor.bench.protocol import ABLATION_METHODS, ALL_METHODS, CONDITIONS, METHODS
from code_as_monitor.bench.record_check import check_episode_record
from code_as_monitor.bench.report_notes import perception_note
from code_as_monitor.bench.results_file import versions_of
from code_as_monitor.bench.runner import episode_records, read_results
from code_as_monitor.core.errors import RunError

HEADERS = {"open-loop": "CLIPort (open-loop)", "inner-monologue": "+Inner Monologue", "doremi": "+DoReMi",
           "cam": "+Ours (CaM)", "cam-mv-off": "CaM, MV off", "cam-cs-off": "CaM, CS off (ORB)",
           "cam-cp-off": "CaM, CP off", "cam-reactive-only": "CaM, reactive only",
           "cam-proactive-only": "CaM, proactive only"}
STANDIN_NOTE = ("Offline (backend `kb`), Inner Monologue's and DoReMi's VQA answers come from `vqa-standin`, "
                "a rule-based single-image stand-in (colour blobs, 2-D image heuristics), not a VLM; the "
                "planner of every method is the `kb` knowledge base, also a rule-based stand-in.")


def _f(x: float, digits: int = 1) -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


CLIP_MARK = "†"
REPORT_KEYS = ("sim_time_s", "vlm", "alarms", "gt")
"""Keys the report reads from every episode record besides the runner's ``REQUIRED_KEYS``."""
BOUNDS = {"success": (0.0, 100.0), "time": (0.0, None)}


def clipped_interval(s: dict[str, Any], lo: float | None, hi: float | None) -> tuple[float, float, bool]:
    """(lower, upper, clipped): the interval ``mean +- ci`` cut to ``[lo, hi]``."""
    m, hw = s["mean"], s["ci"]
    if hw is None or math.isnan(hw):
        return m, m, False
    a, b = m - hw, m + hw
    ca = max(a, lo) if lo is not None else a
    cb = min(b, hi) if hi is not None else b
    return ca, cb, (ca, cb) != (a, b)


def _pm(s: dict[str, Any], digits: int = 1, bounds: tuple[float | None, float | None] = (None, None)) -> str:
    if s is None or math.isnan(s["mean"]):
        return "—"
    a, b, clipped = clipped_interval(s, *bounds)
    if clipped:
        return f"{s['mean']:.{digits}f} ({a:.{digits}f}–{b:.{digits}f}){CLIP_MARK}"
    return f"{s['mean']:.{digits}f} ± {_f(s['ci'], digits)}"


def _check_records(path: str | Path, recs: list[dict[str, Any]]) -> None:
    if not recs:
        raise RunError(f"results {path}: no episode records (empty, or not a cam bench results file)")
    for i, r in enumerate(recs):
        missing = [k for k in REPORT_KEYS if k not in r]
        if missing:
            raise RunError(f"results {path}: episode record {i + 1} ({r['condition']} {r['method']} s{r['seed']}"
                           f"e{r['episode']}) lacks {', '.join(missing)}")
        check_episode_record(path, i + 1, r)


def summarise(path: str | Path) -> dict[str, Any]:
    """Cells, sessions, wall time and code versions of a results file.

    Raises RunError for a file without episode records or with records lacking what the report reads.
    """
    lines = read_results(path)
    recs = episode_records(lines)
    _check_records(path, recs)
    cells: dict[tuple[str, str], dict[str, Any]] = {}
    present_c = [c for c in CONDITIONS if any(r["condition"] == c.id for r in recs)]
    present_m = [m for m in ALL_METHODS if any(r["method"] == m for r in recs)]
    for c in present_c:
        for m in present_m:
            rs = [r for r in recs if r["condition"] == c.id and r["method"] == m]
            if rs:
                cells[(c.id, m)] = {**cell_summary(rs, c.undisturbed),
                                    "video": next((r["video"] for r in rs if r.get("video")), None)}
    known_c, known_m = {c.id for c in present_c}, set(present_m)
    ignored = sorted({f"{r['condition']}/{r['method']}" for r in recs
                      if r["condition"] not in known_c or r["method"] not in known_m})
    return {"conditions": present_c, "methods": present_m, "cells": cells, "records": recs,
            "wall_s": wall_time(lines), "options": next((r["options"] for r in lines if r.get("kind") == "bench_start"),
                                                        {}),
            "versions": versions_of(recs), "ignored": ignored,
            "git": {str(r.get("code_version")): r["git"] for r in lines
                    if r.get("kind") == "bench_start" and r.get("git") and r.get("code_version")}}


def interval_note(summary: dict[str, Any]) -> str:
    """What the ± means in this report's tables (over seeds, or over episodes for one-seed cells)."""
    overs = {k[key]["ci_over"] for k in summary["cells"].values() for key in ("success", "time")}
    ns = sorted({k["success"]["n"] for k in summary["cells"].values()})
    if overs == {"seeds"}:
        how = f"over seeds (the per-seed means; n = {', '.join(map(str, ns))} seeds)"
    elif overs == {"episodes"}:
        how = (f"over episodes, as each cell has a single seed (n = {', '.join(map(str, ns))} episodes); not "
               "comparable with the paper's intervals over seeds")
    else:
        how = "over seeds where a cell has several, over episodes where it has one"
    return (f"Values: mean ± half-width of the 95 % t-interval (t(0.975, n−1) · sd / √n) {how}; no interval "
            f"with n = 1. {CLIP_MARK} the interval reaches past 0–100 % (success) or below 0 s (time) and is "
            "shown as its bounds, clipped to that range.")


def versions_note(summary: dict[str, Any]) -> str:
    """Which code versions made the records (and a warning when the table mixes several)."""
    vs, git = summary["versions"], summary.get("git", {})
    listed = ", ".join(f"`{v}`{f' (git {git[v]})' if v in git else ''}: {n} record(s)" for v, n in vs.items())
    if len(vs) <= 1:
        return f"Code version of every record: {listed}."
    return (f"**Mixed code versions**: the table pools records made by {len(vs)} code versions: {listed}. "
            "Re-run `cam bench` on this file without `--keep-stale` to bring every record to the current code.")


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


def _token_ratio(cam: dict[str, Any] | None, doremi: dict[str, Any] | None) -> str:
    """CaM's mean tokens per episode over DoReMi's, ``"0.62x"`` ("—" without both or with no DoReMi tokens)."""
    if cam is None or doremi is None:
        return "—"
    a, b = float(cam["cost"]["tokens"]), float(doremi["cost"]["tokens"])
    return f"{a / b:.2f}x" if math.isfinite(a) and math.isfinite(b) and b > 0 else "—"


def markdown(summary: dict[str, Any], with_paper: bool = True) -> str:
    """The Markdown tables (ours; the paper's beside it; cost; detection)."""
    ms, cs, cells = summary["methods"], summary["conditions"], summary["cells"]
    checking = [m for m in ms if m != "open-loop"]  # the methods that time themselves and raise alarms
    heads = ["Condition", "n/cell"] + [f"SR {HEADERS[m]}" for m in ms] + [f"Time {HEADERS[m]}" for m in checking]
    opts = summary.get("options") or {}
    perception = perception_note(opts)
    out = [perception, "", interval_note(summary), "", "| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
    for c in cs:
        row = [c.label, str(min((cells[(c.id, m)]["n"] for m in ms if (c.id, m) in cells), default=0))]
        row += [_pm(cells[(c.id, m)]["success"], bounds=BOUNDS["success"]) if (c.id, m) in cells else "—"
                for m in ms]
        row += [_pm(cells[(c.id, m)]["time"], bounds=BOUNDS["time"]) if (c.id, m) in cells else "—"
                for m in ms if m != "open-loop"]
        out.append("| " + " | ".join(row) + " |")
    if with_paper:
        caption = ("Paper (Table 2, OmniGibson, 10 runs per setting; open-loop = ReKep alone; time per task):"
                   if cs and all(c.suite == "table2" for c in cs)
                   else "Paper (supplementary table, 5 seeds x 12 episodes; ± as printed there, a 95 % "
                        "interval over seeds):")
        out += ["", caption, "",
                "| Condition | " + " | ".join(f"SR {HEADERS[m]}" for m in METHODS) + " | "
                + " | ".join(f"Time {HEADERS[m]}" for m in METHODS[1:]) + " |",
                "|---|" + "---|" * (2 * len(METHODS) - 1)]
        for c in cs:
            p = PAPER.get(c.id, {})
            row = [c.label] + [f"{p[m][0]:.2f} ± {p[m][1]:.2f}" if m in p else "—" for m in METHODS]
            row += [f"{p[m][2]:.2f} ± {p[m][3]:.2f}" if m in p and p[m][2] is not None else "—" for m in METHODS[1:]]
            out.append("| " + " | ".join(row) + " |")
    ratio = "cam" in ms and "doremi" in ms  # the token ratio the paper reports (CaM against DoReMi)
    out += ["", "VLM calls / tokens per episode, wall seconds per episode"
            + (" (tokens: estimates offline; last column CaM / DoReMi tokens):" if ratio else ":"), "",
            "| Condition | " + " | ".join(HEADERS[m] for m in ms) + (" | CaM / DoReMi tokens |" if ratio else " |"),
            "|---|" + "---|" * (len(ms) + ratio)]
    for c in cs:
        row = [c.label]
        for m in ms:
            k = cells.get((c.id, m))
            row.append("—" if k is None else f"{_f(k['cost']['calls'])} / {_f(k['cost']['tokens'], 0)} / "
                       f"{_f(k['cost']['wall_s'])} s")
        if ratio:
            row.append(_token_ratio(cells.get((c.id, "cam")), cells.get((c.id, "doremi"))))
        out.append("| " + " | ".join(row) + " |")
    if checking:
        out += ["", "Detection (ours, against the simulator's ground truth): recall (detected/failures), median "
                "latency s, unmatched alarms per episode, proactive precision (confirmed/rollouts), median lead s:",
                "", "| Condition | " + " | ".join(HEADERS[m] for m in checking) + " |",
                "|---|" + "---|" * len(checking)]
    for c in cs if checking else []:
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
    out += rules_table(summary, checking)
    errs = sum(k["errors"] for k in cells.values())
    out += ["", f"Episodes: {len(summary['records'])}, errors: {errs}; wall time of the sessions: "
            f"{summary['wall_s'] / 60:.1f} min.", "", versions_note(summary)]
    if summary.get("ignored"):
        out += ["", f"Not shown (unknown condition or method): {', '.join(summary['ignored'])}."]
    out += ["", STANDIN_NOTE]
    return "\n".join(out) + "\n"


def rules_table(summary: dict[str, Any], checking: list[str]) -> list[str]:
    """Markdown lines: recall, unmatched alarms per episode and proactive precision of every checking method
    under the first round's detection rule (v1) and this one's (v2), on the same records."""
    if not checking:
        return []
    out = ["", "The same records under the first round's detection rule -> this round's (`bench/metrics.py`): "
           "recall, unmatched alarms per episode, proactive precision:", "",
           "| Condition | " + " | ".join(HEADERS[m] for m in checking) + " |", "|---|" + "---|" * len(checking)]

    def fmt(d: dict[str, Any]) -> tuple[str, str, str]:
        rec = f"{d['detected']}/{d['failures']}" if d["failures"] else "—"
        pro = f"{d['proactive_confirmed']}/{d['proactive_alarms']}" if d["proactive_alarms"] else "—"
        return rec, _f(d["unmatched_per_ep"], 2), pro

    for c in summary["conditions"]:
        row = [c.label]
        for m in checking:
            rs = [r for r in summary["records"] if r["condition"] == c.id and r["method"] == m]
            if not rs:
                row.append("—")
                continue
            old, new = fmt(detection(rs, rule="v1")), fmt(detection(rs, rule="v2"))
            row.append(f"R {old[0]} -> {new[0]}; FA {old[1]} -> {new[1]}; P {old[2]} -> {new[2]}")
        out.append("| " + " | ".join(row) + " |")
    return out


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
    for key, title in (("success", "Success rate (%), 95 % t-interval clipped to [0, 100]"),
                       ("time", "Execution time (sim s), 95 % t-interval")):
        fig, ax = plt.subplots(figsize=(10, 3.4))
        for i, m in enumerate(ms):
            mean, err = [], []
            for c in cs:
                k = cells.get((c.id, m))
                if k is None or math.isnan(k[key]["mean"]):
                    mean.append(np.nan)
                    err.append((0.0, 0.0))
                    continue
                lo, hi, _ = clipped_interval(k[key], *BOUNDS[key])  # bars never cross 0 % or 100 %
                mean.append(k[key]["mean"])
                err.append((k[key]["mean"] - lo, hi - k[key]["mean"]))
            ax.bar(x + (i - (len(ms) - 1) / 2) * w, mean, w, yerr=np.array(err).T, capsize=2, label=HEADERS[m])
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
    """Write ``report.md`` and ``report.html`` (self-contained) into ``out_dir``; returns their paths.

    Raises RunError when ``results`` is not a usable results file (see :func:`summarise`) or
    ``out_dir`` exists and is not a directory; nothing is written then.
    """
    import markdown_it

    out = Path(out_dir)
    s = summarise(results)
    if out.exists() and not out.is_dir():
        raise RunError(f"report directory {out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    suites = {c.suite for c in s["conditions"]}
    title = {"table2": "Table 2 benchmark", "rlbench": "RLBench-style benchmark"}.get(
        suites.pop() if len(suites) == 1 else "", "CLIPort benchmark")
    if set(s["methods"]) & set(ABLATION_METHODS):
        from code_as_monitor.bench.report_ablation import ablation_markdown

        title = "Ablation"
        body_md = ablation_markdown(s) + "\n" + versions_note(s) + "\n"
    elif title == "RLBench-style benchmark":
        from code_as_monitor.bench.report_rlbench import rlbench_markdown

        body_md = (perception_note(s.get("options") or {}) + "\n\n" + rlbench_markdown(s["records"]) + "\n"
                   + versions_note(s)) + "\n\n" + STANDIN_NOTE + "\n"
    else:
        body_md = markdown(s)
    md = f"# {title}\n\nResults: `{results}`\n\n" + body_md
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


__all__ = ["HEADERS", "STANDIN_NOTE", "clipped_interval", "interval_note", "markdown", "plots", "summarise",
           "versions_note", "wall_time", "write_report"]
