"""Compare two painter versions element by element on the same scenes (records of ``element_accuracy.py --records``).

Both files must come from the same ``--seeds``, ``--every`` and ``--tasks`` (the same scenes, views and depth-noise
draws, so record ``i`` is the same element of the same frame in both); a pair whose task, scene, views, noise or
element differ stops the comparison. Perception as in ``element_accuracy.py``: ``sim`` segmenter masks and the
painter's geometry, no tracker; planner: none.

Printed: every element whose error moved by more than ``--threshold`` (mm for point-like errors, degrees for
directions and normals), largest first, with the painter's own verdict before and after (``w``: weak); then counts of
elements that got better and worse, of large errors (over 8 mm) the painter knows about (weak, or an uncertainty of at
least half the error) and of large errors it does not; ending with ``name: value unit`` lines.

Run: ``.venv/bin/python benchmarks/compare_elements.py BEFORE.jsonl AFTER.jsonl [--threshold 3] [--top 40]``.
"""

from __future__ import annotations

import argparse
import json
import sys

LARGE_MM = 8.0
"""A point-like error (mm) above the two-view point target, as in ``element_accuracy.py``."""
KEYS = ("task", "label", "views", "noise", "name", "kind")


def load(path: str) -> list[dict]:
    """The records of ``path`` in file order."""
    with open(path) as f:
        return [json.loads(line) for line in f if line.strip()]


def _scale(metric: str) -> float:
    return 1.0 if metric.endswith("_deg") else 1000.0


def point_like_mm(r: dict) -> float:
    """The largest point-like error of a record (mm), 0 when it has none."""
    vals = [v for k, v in (r["errors"] or {}).items() if not k.endswith("_deg")]
    return 1000.0 * max(vals) if vals else 0.0


def knows(r: dict) -> bool:
    """Whether the painter flags a large error: weak, or an uncertainty of at least half the error."""
    e = point_like_mm(r)
    return bool(r["weak"]) or 1000.0 * float(r["uncertainty"]) >= 0.5 * e


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--threshold", type=float, default=3.0, help="mm or degrees an error must move to be listed")
    ap.add_argument("--top", type=int, default=40, help="how many moved elements to print")
    args = ap.parse_args(argv)
    loaded = []
    for path in (args.before, args.after):
        try:
            loaded.append(load(path))
        except (OSError, json.JSONDecodeError) as exc:
            print(f"compare_elements: cannot read the records {path}: {exc}", file=sys.stderr)
            return 2
    a, b = loaded
    if len(a) != len(b):
        print(f"compare_elements: {args.before} has {len(a)} records, {args.after} {len(b)}: not the same scenes",
              file=sys.stderr)
        return 2
    moved, scored = [], 0
    large = {"before": [0, 0], "after": [0, 0]}  # [flagged, large], two views and the front view together
    for x, y in zip(a, b):
        if any(x[k] != y[k] for k in KEYS):
            print(f"compare_elements: record {x['i']} is {[x[k] for k in KEYS]} in one file and "
                  f"{[y[k] for k in KEYS]} in the other: not the same scenes", file=sys.stderr)
            return 2
        if x["errors"] is None or y["errors"] is None:
            continue
        scored += 1
        for tag, r in (("before", x), ("after", y)):
            if point_like_mm(r) > LARGE_MM:
                large[tag][1] += 1
                large[tag][0] += knows(r)
        for m in sorted(set(x["errors"]) & set(y["errors"])):
            d = (y["errors"][m] - x["errors"][m]) * _scale(m)
            if abs(d) > args.threshold:
                moved.append((abs(d), d, x, y, m))
    moved.sort(key=lambda t: -t[0])
    print(f"{scored} elements scored in both; {len(moved)} errors moved by more than {args.threshold:g} mm or deg:")
    for _, d, x, y, m in moved[: args.top]:
        u = "deg" if m.endswith("_deg") else "mm"
        print(f"  {d:+7.1f} {u:<3} {x['task']:<18} {x['name']:<26} {x['label']:<24} {x['views']:<9} "
              f"noise {x['noise']:.0f} mm  {m:<13} {x['errors'][m] * _scale(m):7.1f}{'w' if x['weak'] else ' '} -> "
              f"{y['errors'][m] * _scale(m):7.1f}{'w' if y['weak'] else ' '}")
    better = sum(d < 0 for _, d, *_ in moved)
    print(f"elements_better: {better} count")
    print(f"elements_worse: {len(moved) - better} count")
    for tag in ("before", "after"):
        print(f"large_errors_flagged_{tag}: {large[tag][0]}/{large[tag][1]} count")
    return 0


if __name__ == "__main__":
    sys.exit(main())
