"""CaM's cells of two ``cam bench`` results files side by side (e.g. ``--tracker sim`` against ``--tracker depth``,
or the same tracker before and after a change), paired on the episodes both files finished: success, the episodes
only one side passes, unmatched alarms per episode (false alarms in undisturbed conditions), recall and median
latency, proactive precision (confirmed / rolled out), re-plans and wall time per episode. The metrics are
:func:`code_as_monitor.bench.metrics.detection`'s, the ones ``cam report`` prints. ``--episodes`` also lists every
paired episode whose outcome, re-plans, alarm count or simulated duration differ, with the record's ``cam run``
command that replays it.

Run: ``.venv/bin/python benchmarks/compare_trackers.py ORACLE.jsonl OTHER.jsonl [--names sim,depth] [--episodes]``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from code_as_monitor.bench.metrics import detection


def load(path: str, until: float | None = None) -> dict[tuple, dict[str, Any]]:
    """CaM episode records without an error (finished before ``until``, epoch s), by (condition, seed, episode)."""
    out = {}
    with open(path) as fh:
        for line in fh:
            r = json.loads(line)
            if until is not None and r.get("kind") == "episode" and (r.get("finished_at") or 0.0) >= until:
                continue
            if r.get("kind") == "episode" and r.get("method") == "cam" and not r.get("error"):
                out[(r["condition"], r["seed"], r["episode"])] = r
    return out


def _fa(d: dict[str, Any], undisturbed: bool) -> str:
    return f"{d['unmatched_per_ep']:.2f}" + ("" if undisturbed else " (unmatched)")


def _recall(d: dict[str, Any]) -> str:
    return "—" if not d["failures"] else f"{100 * d['recall']:.0f}% ({d['detected']}/{d['failures']})"


def _precision(d: dict[str, Any]) -> str:
    return "—" if not d.get("proactive_alarms") else f"{d['proactive_confirmed']}/{d['proactive_alarms']}"


def _signature(r: dict[str, Any]) -> tuple:
    """What a replayed episode must reproduce: outcome, re-plans, alarms, simulated duration (0.01 s)."""
    return (bool(r["success"]), r["replans"], len(r.get("alarms") or ()), round(float(r.get("sim_time_s") or 0.0), 2))


def _lat(d: dict[str, Any]) -> str:
    return "—" if d["latency_median"] != d["latency_median"] else f"{d['latency_median']:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("oracle")
    ap.add_argument("other")
    ap.add_argument("--names", default="sim,depth", help="column names of the two files")
    ap.add_argument("--episodes", action="store_true",
                    help="list the paired episodes that ran differently (outcome, re-plans, alarms, duration)")
    ap.add_argument("--until", type=float, default=None,
                    help="only episodes finished before this time (epoch seconds), e.g. before the code changed")
    args = ap.parse_args(argv)
    for path in (args.oracle, args.other):
        if not os.path.isfile(path):
            print(f"compare_trackers: no results file {path!r}", file=sys.stderr)
            return 2
    if args.names.count(",") != 1:
        print(f"compare_trackers: --names must be two comma-separated names, got {args.names!r}", file=sys.stderr)
        return 2
    na, nb = args.names.split(",")
    try:
        a, b = load(args.oracle, args.until), load(args.other, args.until)
    except (json.JSONDecodeError, KeyError) as exc:
        print(f"compare_trackers: not a cam bench results file ({type(exc).__name__}: {exc})", file=sys.stderr)
        return 2
    common = sorted(set(a) & set(b))
    conds = list(dict.fromkeys(k[0] for k in common))
    print(f"| Condition | n | SR {na} | SR {nb} | {nb} - {na} (points) | only {na} / only {nb} ok | FA/ep {na} | "
          f"FA/ep {nb} | recall {na} | recall {nb} | latency s {na} / {nb} | proactive P {na} / {nb} | "
          f"re-plans/ep {na} / {nb} | wall s/ep {na} / {nb} |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for c in conds:
        ks = [k for k in common if k[0] == c]
        ra, rb = [a[k] for k in ks], [b[k] for k in ks]
        sa = 100 * sum(r["success"] for r in ra) / len(ks)
        sb = 100 * sum(r["success"] for r in rb) / len(ks)
        da, db = detection(ra), detection(rb)
        und = bool(ra[0].get("undisturbed"))
        rp_a, rp_b = (sum(r["replans"] for r in rs) / len(rs) for rs in (ra, rb))
        w_a, w_b = (sum(r.get("wall_time_s") or 0.0 for r in rs) / len(rs) for rs in (ra, rb))
        only_a = sum(x["success"] and not y["success"] for x, y in zip(ra, rb))
        only_b = sum(y["success"] and not x["success"] for x, y in zip(ra, rb))
        print(f"| {c} | {len(ks)} | {sa:.1f} | {sb:.1f} | {sb - sa:+.1f} | {only_a} / {only_b} | {_fa(da, und)} | "
              f"{_fa(db, und)} | {_recall(da)} | {_recall(db)} | {_lat(da)} / {_lat(db)} | "
              f"{_precision(da)} / {_precision(db)} | {rp_a:.1f} / {rp_b:.1f} | {w_a:.0f} / {w_b:.0f} |")
    ua = [a[k] for k in common if a[k].get("undisturbed")]
    ub = [b[k] for k in common if b[k].get("undisturbed")]
    da, db = detection([a[k] for k in common]), detection([b[k] for k in common])
    differ = [k for k in common if _signature(a[k]) != _signature(b[k])]
    print(f"\nepisodes in both files: {len(common)}; in one only: {len(set(a) ^ set(b))}; "
          f"ran differently: {len(differ)}")
    if args.episodes:
        for k in differ:
            print(f"  {k[0]} seed {k[1]} episode {k[2]}: (success, re-plans, alarms, sim s) {na} {_signature(a[k])}, "
                  f"{nb} {_signature(b[k])}; replay: {b[k].get('run', '?')}")
    if ua:
        print(f"false_alarms_per_undisturbed_episode_{na}: {detection(ua)['unmatched_per_ep']:.3f} /ep (n={len(ua)})")
        print(f"false_alarms_per_undisturbed_episode_{nb}: {detection(ub)['unmatched_per_ep']:.3f} /ep (n={len(ub)})")
    print(f"recall_{na}: {da['detected']}/{da['failures']} failures")
    print(f"recall_{nb}: {db['detected']}/{db['failures']} failures")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
