"""Benchmark: VLM tokens per episode of Code-as-Monitor against DoReMi, per condition row of both suites.

Runs ``--episodes`` episodes (seed index 0, the benchmark's episode seeds) of ``cam`` and ``doremi`` on every
row of the ``cliport`` and ``table2`` suites and prints, per row, the mean tokens per episode (prompt +
completion, every planner, coder and VQA call) of each method, split by purpose, and CaM / DoReMi.

The counts are ESTIMATES, not a model's usage: offline, the kb planner and coder (a rule-based stand-in for a
VLM, not a VLM) and DoReMi's ``vqa-standin`` answer, and every request is counted as a VLM would be sent it
(text: 4 characters per token; each image by GPT-4o's tile rule for its size and detail,
``code_as_monitor.vlm.usage.image_tokens``). Perception is the oracle ``sim`` tracker/segmenter. Counterfactual
rollouts are off (they restore the world exactly and ask no VLM, so tokens do not change).

DoReMi's VQA requests are the baseline's own and go at the backend's default detail (``auto``, estimated as
``high``: 255 tokens for a 320 x 240 view); CaM's planner and coder send their views at detail ``low`` (85),
which loses nothing for views that fit in 512 x 512. ``tokens_ratio_if_vqa_low`` gives the ratio had DoReMi's
VQA images gone at ``low`` too (the same principle applied to both).

Run: ``nice -n 10 .venv/bin/python benchmarks/tokens.py [--episodes 2] [--suites cliport,table2]
[--conditions stack-p0,rope]``. The last lines are machine-readable: ``tokens_ratio_<row>: <x> x``, the same
with DoReMi's VQA at low detail, and ``planner_only_ratio_<row>: <x> x``: CaM's planner tokens alone over DoReMi's
total, the ratio CaM would have with a coder that cost nothing (the planner is the same for both methods, so where
this is above 0.5, no coder, however lean, brings the row to 0.5).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from typing import Any

from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.protocol import SUITES, Job
from code_as_monitor.vlm.usage import image_tokens

METHODS = ("cam", "doremi")
VIEW_W, VIEW_H = 320, 240
"""The benchmark's camera views (``WorldConfig`` defaults)."""


def vqa_low_saving() -> int:
    """Tokens a VQA call would save with its 320 x 240 image at detail low instead of auto."""
    return image_tokens(VIEW_W, VIEW_H, "auto") - image_tokens(VIEW_W, VIEW_H, "low")


def row(condition: str, episodes: int, opts: EpisodeOptions) -> dict[str, Any]:
    """Mean tokens, calls and tokens by purpose per episode of each method on ``condition``."""
    out: dict[str, Any] = {}
    for m in METHODS:
        tot, calls, by, vqa_calls, ok = [], [], {}, [], []
        for e in range(episodes):
            rec = run_episode(Job(m, condition, 0, e), opts)
            if rec.get("error"):
                print(f"  {m} {condition} e{e}: error {rec['error']}", file=sys.stderr)
            v = rec["vlm"]
            ok.append(bool(rec["success"]))
            tot.append(v["total_tokens"])
            calls.append(v["calls"])
            vqa_calls.append(v["calls_by_purpose"].get("vqa", 0))
            for p, n in (v.get("tokens_by_purpose") or {}).items():
                by.setdefault(p, []).append(n)
        out[m] = {"tokens": statistics.fmean(tot), "calls": statistics.fmean(calls),
                  "by": {p: sum(ns) / episodes for p, ns in by.items()}, "vqa_calls": statistics.fmean(vqa_calls),
                  "success": sum(ok) / len(ok)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=2, help="episodes per method and row (seed index 0)")
    ap.add_argument("--suites", default="cliport,table2", help="comma list of suites")
    ap.add_argument("--conditions", default="", help="comma list of condition ids (overrides --suites)")
    args = ap.parse_args(argv)
    conds = [c for c in args.conditions.split(",") if c] or [
        c for s in args.suites.split(",") if s for c in SUITES[s]]
    opts = EpisodeOptions(counterfactual=False)
    saving = vqa_low_saving()
    print("Estimated tokens per episode (kb planner/coder and vqa-standin, not a VLM; oracle sim tracker); "
          f"{args.episodes} episode(s) per row, seed 0")
    print(f"{'row':14s} {'CaM':>8s} {'DoReMi':>8s} {'ratio':>6s}  CaM by purpose | DoReMi by purpose")
    ratios, low, planner_only = {}, {}, {}
    for c in conds:
        r = row(c, args.episodes, opts)
        cam, dor = r["cam"], r["doremi"]
        ratios[c] = cam["tokens"] / dor["tokens"] if dor["tokens"] else float("nan")
        planner_only[c] = cam["by"].get("constraint_generator", 0.0) / dor["tokens"] if dor["tokens"] else float("nan")
        dor_low = dor["tokens"] - saving * dor["vqa_calls"]
        low[c] = cam["tokens"] / dor_low if dor_low else float("nan")
        fmt = lambda by: " ".join(f"{p} {n:.0f}" for p, n in sorted(by.items()))  # noqa: E731
        print(f"{c:14s} {cam['tokens']:8.0f} {dor['tokens']:8.0f} {ratios[c]:6.2f}  {fmt(cam['by'])} | "
              f"{fmt(dor['by'])}  (calls {cam['calls']:.1f} / {dor['calls']:.1f}; success "
              f"{cam['success']:.0%} / {dor['success']:.0%})", flush=True)
    for c, x in ratios.items():
        print(f"tokens_ratio_{c}: {x:.2f} x")
    for c, x in low.items():
        print(f"tokens_ratio_if_vqa_low_{c}: {x:.2f} x")
    for c, x in planner_only.items():
        print(f"planner_only_ratio_{c}: {x:.2f} x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
