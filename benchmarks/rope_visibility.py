"""What the cameras let the monitor prove on the rope task: per frame, how much of the opening is covered by the
rope's beads as they truly lie, by the beads some view sees, and by the beads the tracker reports fresh.

Why. The rope's completion check ("resting beads lie along 90 % of the opening, steadily for ``stable_s``") is
judged on the beads the tracker reports fresh (a bead the cameras do not see gives no evidence; the check reads
its beads as monotone members, so an unseen bead is left out, never guessed). When the arm hovers over the opening
it hides the beads that close it, and no window of ``stable_s`` may exist in which the *seen* beads cover 90 %,
however good the tracker. This script separates the two limits on one closed-loop episode per seed:

* ``true``: every bead at its true position (the simulator's poses, read by this benchmark only);
* ``visible``: the true positions of the beads whose mask has at least ``detect_min_pixels`` valid depth pixels in
  some view (the depth tracker's own rule for a detection): an ideal tracker of what the cameras see;
* ``fresh``: the tracker's fresh bead estimates (identities ignored, as the check reads them).

Each is scored with the check's own rule (the kb's ``rope_cover`` thresholds: samples along corner_3 - corner_0
within ``max_gap - margin``, a bead above ``max_z`` counts as carried), with the corners at their true positions,
and the windows of at least ``stable_s`` in which it stays at or above ``min_fraction`` are listed. Planner and
coder ``kb`` (a rule-based stand-in for a VLM, not a VLM), elements painted from ``sim`` masks, two 320x240 views
at 10 Hz, ``cam bench``'s per-frame deadline.

Run: ``nice -n 10 .venv/bin/python benchmarks/rope_visibility.py --seeds 1023307162,1368553411 [--tracker depth]``
(episode seeds as the benchmark records write them). Lines ``name: value unit`` end the output.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import code_as_monitor.perception as perception  # noqa: E402
import tracking  # noqa: E402
from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop  # noqa: E402
from code_as_monitor.bench.episode import BENCH_DEADLINE_S  # noqa: E402
from code_as_monitor.core.observation import Observation  # noqa: E402
from code_as_monitor.perception.trackers.base import DepthTrackerConfig, TrackResult  # noqa: E402
from code_as_monitor.vlm.kb.families.rope import THRESHOLDS  # noqa: E402

RULE = THRESHOLDS["rope_cover"]
KINDS = ("true", "visible", "fresh")


def covered(a: np.ndarray, b: np.ndarray, beads: np.ndarray) -> float:
    """The check's coverage of the opening a-b (3,) by beads (n, 3), world metres."""
    if len(beads) == 0:
        return 0.0
    s = np.linspace(0.0, 1.0, int(RULE["samples"]))
    samples = a[None, :2] + s[:, None] * (b - a)[None, :2]
    carried = np.maximum(beads[:, 2] - RULE["max_z"], 0.0) * 1000.0
    d = np.linalg.norm(samples[:, None, :] - beads[None, :, :2], axis=2) + carried[None, :]
    return float(np.mean(d.min(axis=1) <= RULE["max_gap"] - RULE["margin"]))


def windows(t: np.ndarray, ok: np.ndarray, least: float) -> list[tuple[float, float]]:
    """(start, end) of every run of frames with ``ok`` lasting at least ``least`` seconds."""
    out: list[tuple[float, float]] = []
    start = end = None
    for ti, o in [*zip(t, ok), (np.inf, False)]:
        if o:
            start = ti if start is None else start
            end = ti
        elif start is not None and end is not None:
            if end - start >= least - 1e-9:
                out.append((float(start), float(end)))
            start = end = None
    return out


class Visibility(tracking.ScoredTracker):
    """Records, per frame, the three coverages of the opening (the corners at their true poses)."""

    def __init__(self, inner, min_pixels: int) -> None:
        super().__init__(inner)
        self.min_pixels = min_pixels
        self.rows: list[tuple[float, float, float, float]] = []

    def step(self, obs: Observation) -> TrackResult:
        res = super().step(obs)
        poses = obs.object_poses or {}
        if "square/corner_0" not in poses or "square/corner_3" not in poses:
            return res
        a, b = poses["square/corner_0"][:3, 3], poses["square/corner_3"][:3, 3]
        true, seen, fresh = [], [], []
        for eid, (key, L) in self.local.items():
            if not key.startswith("rope/") or key not in poses:
                continue
            T = poses[key]
            p = (L @ T[:3, :3].T + T[:3, 3]).mean(axis=0)
            true.append(p)
            obj, _, part = key.partition("/")
            if any(int((v.mask_of(obj, part) & np.isfinite(v.depth) & (v.depth > 0)).sum()) >= self.min_pixels
                   for v in obs.views.values()):
                seen.append(p)
            if eid in res.points and not np.any(res.stale[eid]):
                fresh.append(res.points[eid].mean(axis=0))
        self.rows.append((obs.t, *(covered(a, b, np.array(x).reshape(-1, 3)) for x in (true, seen, fresh))))
        return res


def run(seed: int, tracker: str) -> dict[str, list[tuple[float, float]]]:
    made: list[Visibility] = []
    orig = perception.make_tracker

    def wrap(cfg):
        made.append(Visibility(orig(cfg), DepthTrackerConfig().detect_min_pixels))
        return made[-1]

    perception.make_tracker = wrap
    try:
        summary = run_closed_loop(ClosedLoopConfig(task="rope-close-square", seed=seed, task_params={}, tracker=tracker,
                                                   width=320, height=240, video=False, deadline_s=BENCH_DEADLINE_S))
    finally:
        perception.make_tracker = orig
    rows = np.array([r for v in made for r in v.rows])
    t = rows[:, 0]
    out = {k: windows(t, rows[:, i + 1] >= RULE["min_fraction"], RULE["stable_s"]) for i, k in enumerate(KINDS)}
    print(f"seed {seed} ({tracker}): {'success' if summary['success'] else 'failure'}, {summary.get('reason')}; "
          f"{len(rows)} frames")
    for k in KINDS:
        spans = ", ".join(f"{s:.1f}-{e:.1f}" for s, e in out[k]) or "none"
        print(f"  {k:8s} >= {RULE['min_fraction']:.0%} for >= {RULE['stable_s']} s: {spans}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", required=True, help="comma list of episode seeds")
    ap.add_argument("--tracker", default="depth")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    found = {k: 0 for k in KINDS}
    for seed in seeds:
        res = run(seed, args.tracker)
        for k in KINDS:
            found[k] += bool(res[k])
    for k in KINDS:
        print(f"rope_episodes_with_{k}_window: {found[k]} of {len(seeds)} episodes")


if __name__ == "__main__":
    main()
