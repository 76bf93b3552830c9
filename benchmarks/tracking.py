"""Tracking accuracy over whole closed-loop episodes, and the per-frame cost of the trackers.

Accuracy: for every tracker in ``--trackers`` (``lk``, ``depth``, ``sim``) and every condition in
``--conditions`` (default: one disturbed condition per task: carried, dropped, collapsed, pushed, knocked,
tilted and slipped objects, occluded by the arm), one closed-loop Code-as-Monitor episode per seed:
planner and coder ``kb`` (a rule-based stand-in for a VLM, not a VLM), elements painted from ``sim``
masks, two 320x240 views at 10 Hz, and ``cam bench``'s per-frame sandbox deadline (0.5 s; with the robot's
20 ms, frames overrun on a busy machine, each overrun is a fault and replaces the sandbox worker, so the
episodes would depend on the load). The tracker the agent uses is wrapped: every frame, each element it
reports fresh is scored against ground truth, its painted points carried along with its owner's true
pose (``Observation.object_poses``, read here by the benchmark only, never by the ``lk``/``depth``
trackers), re-anchored when the agent re-paints it. Per element kind: position error (point: the point;
line: the worse end; surface: the centroid) median / p95 / max in mm, and for lines and surfaces the
direction / normal error in degrees; the share of element-frames that were stale; the step time. Points are
also scored identity-free (``point*``): each frame, the fresh point estimates paired with the truths of all
point elements (fresh or stale) by the one-to-one assignment of least total distance, which is what a
tracker of anonymous identical objects (a pile of blocks, a rope's beads) can be asked for.
Episodes differ between trackers (the monitor's verdicts steer them); every table names its tracker.

Speed: the demo episode (``cam demo``: stack-in-order, p = 0.3, seed 10) is run with the ``depth``
tracker, its frames recorded, then replayed ``--runs`` times through ``depth`` and ``lk`` (the reference,
on the same frames and elements), one thread each: medians of the per-run step-time medians and p95s.

Run: ``nice -n 10 .venv/bin/python benchmarks/tracking.py [--trackers lk,depth,sim] [--seeds 1]
[--conditions ...] [--out runs/tracking.jsonl] [--skip-accuracy | --skip-speed]``; finished episodes in
``--out`` are not run again. Lines ``name: value unit`` end the output.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one core: set before numpy loads

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

import code_as_monitor.perception as perception  # noqa: E402
from code_as_monitor.core.elements import Element, ElementKind  # noqa: E402
from code_as_monitor.core.observation import Observation, View  # noqa: E402
from code_as_monitor.perception.trackers.base import Tracker, TrackerConfig, TrackResult  # noqa: E402

CONDITIONS = ("stack-p0.3", "stack-q3", "sweep-half", "rope", "pen-b", "pen-c", "book-a", "tea-a", "drawer-slip")
DEMO = ("stack-in-order", {"p": 0.3}, 10)


def _owner_key(poses: dict[str, np.ndarray], owner: tuple[str, str]) -> str:
    obj, part = owner
    return f"{obj}/{part}" if part and f"{obj}/{part}" in poses else obj


class ScoredTracker(Tracker):
    """Wraps the agent's tracker: times every step and scores every fresh element against the truth."""

    def __init__(self, inner: Tracker, record: bool = False) -> None:
        super().__init__()
        self.inner = inner
        self.local: dict[int, tuple[str, np.ndarray]] = {}  # element id -> (pose key, owner-frame points)
        self.kind: dict[int, ElementKind] = {}
        self.err: dict[str, list[float]] = {"point": [], "line": [], "surface": [], "point_anon": []}
        self.deg: dict[str, list[float]] = {"line": [], "surface": []}
        self.frames = self.stale = 0
        self.times: list[float] = []
        self.record = record
        self.log: list[tuple[str, Any]] = []  # ("reset", (obs, elements)) / ("step", obs), for the replay

    def set_reacquire(self, fn) -> None:
        def hook(obs: Observation, el: Element) -> Element | None:
            new = fn(obs, el)
            if new is not None:
                self._anchor(obs, new)
            return new

        self.inner.set_reacquire(None if fn is None else hook)

    def set_segmenter(self, segmenter) -> None:
        if hasattr(self.inner, "set_segmenter"):
            self.inner.set_segmenter(segmenter)

    def _anchor(self, obs: Observation, el: Element) -> None:
        if el.owner[0] == "robot" or obs.object_poses is None:
            return
        key = _owner_key(obs.object_poses, el.owner)
        T = obs.object_poses[key]
        self.local[el.id] = (key, (el.points - T[:3, 3]) @ T[:3, :3])
        self.kind[el.id] = el.kind

    def reset(self, obs: Observation, elements: list[Element]) -> None:
        self.local.clear()
        for el in elements:
            self._anchor(obs, el)
        if self.record:
            self.log.append(("reset", (_light(obs), elements)))
        self.inner.reset(obs, elements)

    def step(self, obs: Observation) -> TrackResult:
        t0 = time.thread_time()
        res = self.inner.step(obs)
        self.times.append(time.thread_time() - t0)
        if self.record:
            self.log.append(("step", _light(obs)))
        est, true = [], []
        for eid, (key, L) in self.local.items():
            if eid not in res.points or obs.object_poses is None or key not in obs.object_poses:
                continue
            self.frames += 1
            T = obs.object_poses[key]
            truth = L @ T[:3, :3].T + T[:3, 3]
            if self.kind[eid] is ElementKind.POINT:
                true.append(truth[0])
            if np.any(res.stale[eid]):
                self.stale += 1
                continue
            self._score(self.kind[eid], res.points[eid], truth)
            if self.kind[eid] is ElementKind.POINT:
                est.append(res.points[eid][0])
        if est:
            self.err["point_anon"] += _anonymous_errors(np.array(est), np.array(true))
        return res

    def _score(self, kind: ElementKind, P: np.ndarray, truth: np.ndarray) -> None:
        if kind is ElementKind.POINT:
            self.err["point"].append(float(np.linalg.norm(P[0] - truth[0])))
        elif kind is ElementKind.LINE:
            self.err["line"].append(float(np.linalg.norm(P - truth, axis=1).max()))
            self.deg["line"].append(_angle(P[1] - P[0], truth[1] - truth[0], signed=True))
        else:
            self.err["surface"].append(float(np.linalg.norm(P.mean(axis=0) - truth.mean(axis=0))))
            self.deg["surface"].append(_angle(_normal(P), _normal(truth), signed=False))


def _anonymous_errors(est: np.ndarray, truth: np.ndarray) -> list[float]:
    """Identity-free point errors of one frame: each fresh point estimate (n, 3) against the truth it is paired
    with, among the truths (m >= n, 3) of every point element scored this frame, fresh or stale, by the
    one-to-one assignment of least total distance (what a tracker of anonymous, identical objects can be
    asked for: where the objects are, not which is which)."""
    from scipy.optimize import linear_sum_assignment

    D = np.linalg.norm(est[:, None] - truth[None], axis=2)
    r, c = linear_sum_assignment(D)
    return [float(x) for x in D[r, c]]


def _angle(a: np.ndarray, b: np.ndarray, signed: bool) -> float:
    c = float(a @ b / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-12))
    return float(np.degrees(np.arccos(np.clip(c if signed else abs(c), -1.0, 1.0))))


def _normal(P: np.ndarray) -> np.ndarray:
    return np.linalg.svd(P - P.mean(axis=0))[2][2]


def _light(obs: Observation) -> Observation:
    """The observation without segmentation and ground truth (what a tracker may use), for the replay."""
    views = {n: View(v.rgb, v.depth, v.camera) for n, v in obs.views.items()}
    return dataclasses.replace(obs, views=views, object_poses=None)


def run_episode(tracker: str, cid: str, seed: int, record: bool = False) -> tuple[dict[str, Any], ScoredTracker]:
    """One closed-loop episode of condition ``cid`` with ``tracker``; its scores."""
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
    from code_as_monitor.bench.episode import BENCH_DEADLINE_S
    from code_as_monitor.bench.protocol import condition, episode_seed

    cond = condition(cid) if cid != "demo" else None
    task, params, sim_seed = (cond.task, dict(cond.params), episode_seed(cid, seed, 0)) if cond else DEMO
    made: list[ScoredTracker] = []
    original = perception.make_tracker

    def make(cfg: TrackerConfig) -> Tracker:
        made.append(ScoredTracker(original(cfg), record))
        return made[-1]

    perception.make_tracker = make  # run_closed_loop imports it from the package when it runs
    try:
        t0 = time.perf_counter()
        summary = run_closed_loop(ClosedLoopConfig(task=task, seed=sim_seed, task_params=params, tracker=tracker,
                                                   width=320, height=240, video=False,
                                                   deadline_s=BENCH_DEADLINE_S))
    finally:
        perception.make_tracker = original
    sc = made[0]
    rec = {"tracker": tracker, "condition": cid, "seed": seed, "success": summary["success"],
           "wall_s": round(time.perf_counter() - t0, 1), "frames": sc.frames, "stale": sc.stale,
           "step_ms": [round(1e3 * t, 3) for t in sc.times],
           "err_mm": {k: [round(1e3 * e, 3) for e in v] for k, v in sc.err.items()},
           "deg": {k: [round(d, 3) for d in v] for k, v in sc.deg.items()}}
    return rec, sc


def _stats(x: list[float]) -> tuple[float, float, float, int]:
    a = np.asarray(x, dtype=float)
    if not len(a):
        return (float("nan"),) * 3 + (0,)  # type: ignore[return-value]
    return float(np.median(a)), float(np.percentile(a, 95)), float(a.max()), len(a)


def report(records: list[dict[str, Any]], trackers: list[str]) -> None:
    """The accuracy table per tracker and kind, then the ``name: value unit`` lines."""
    lines = []
    conds = sorted({r["condition"] for r in records})
    print(f"\naccuracy over {len(conds)} condition(s): {', '.join(conds)}; planner kb (stand-in, not a VLM), "
          "painter on sim masks; sim = the oracle tracker")
    print(f"{'tracker':7s} {'kind':8s} {'n':>6s} {'median mm':>10s} {'p95 mm':>8s} {'max mm':>8s} "
          f"{'median deg':>11s} {'p95 deg':>8s} {'max deg':>8s}")
    for tr in trackers:
        rs = [r for r in records if r["tracker"] == tr]
        if not rs:
            continue
        allpos: list[float] = []
        for kind in ("point", "line", "surface"):
            e = [x for r in rs for x in r["err_mm"][kind]]
            allpos += e
            d = [x for r in rs for x in r["deg"].get(kind, [])]
            m, p, mx, n = _stats(e)
            dm, dp, dmx, _ = _stats(d)
            print(f"{tr:7s} {kind:8s} {n:6d} {m:10.2f} {p:8.2f} {mx:8.1f} "
                  + (f"{dm:11.2f} {dp:8.2f} {dmx:8.1f}" if kind != "point" else ""))
            if n:
                lines += [f"{tr}_{kind}_err_median: {m:.2f} mm", f"{tr}_{kind}_err_p95: {p:.2f} mm",
                          f"{tr}_{kind}_err_max: {mx:.1f} mm"]
                if kind != "point":
                    lines += [f"{tr}_{kind}_deg_median: {dm:.2f} deg", f"{tr}_{kind}_deg_p95: {dp:.2f} deg"]
        m, p, mx, n = _stats([x for r in rs for x in r["err_mm"].get("point_anon", [])])
        if n:  # the same fresh points, paired with the truths without their identities
            print(f"{tr:7s} {'point*':8s} {n:6d} {m:10.2f} {p:8.2f} {mx:8.1f}   (* identity-free: paired per frame)")
            lines += [f"{tr}_point_anon_err_median: {m:.2f} mm", f"{tr}_point_anon_err_p95: {p:.2f} mm",
                      f"{tr}_point_anon_err_max: {mx:.1f} mm"]
        m, p, mx, n = _stats(allpos)
        frames, stale = sum(r["frames"] for r in rs), sum(r["stale"] for r in rs)
        sm, sp, _, _ = _stats([x for r in rs for x in r["step_ms"]])
        ok = sum(r["success"] for r in rs)
        print(f"{tr:7s} {'all':8s} {n:6d} {m:10.2f} {p:8.2f} {mx:8.1f}   stale {100 * stale / max(frames, 1):.1f} % "
              f"of {frames} element-frames; step median {sm:.2f} ms, p95 {sp:.2f} ms; {ok}/{len(rs)} episodes "
              "succeeded")
        lines += [f"{tr}_err_median: {m:.2f} mm", f"{tr}_err_p95: {p:.2f} mm", f"{tr}_err_max: {mx:.1f} mm",
                  f"{tr}_stale: {100 * stale / max(frames, 1):.2f} %", f"{tr}_episode_step_median: {sm:.3f} ms",
                  f"{tr}_episode_step_p95: {sp:.3f} ms"]
    print("\nper condition (position error median / p95 mm, stale %; identity-free point error median / p95 mm):")
    for cid in conds:
        cells = []
        for tr in trackers:
            rs = [r for r in records if r["tracker"] == tr and r["condition"] == cid]
            e = [x for r in rs for k in r["err_mm"] if k != "point_anon" for x in r["err_mm"][k]]
            fr, st = sum(r["frames"] for r in rs), sum(r["stale"] for r in rs)
            m, p, _, _ = _stats(e)
            am, ap, _, an = _stats([x for r in rs for x in r["err_mm"].get("point_anon", [])])
            cells.append(f"{tr} {m:5.2f}/{p:6.2f} {100 * st / max(fr, 1):4.1f}%"
                         + (f" (point* {am:.2f}/{ap:.2f})" if an else ""))
        print(f"  {cid:12s} " + "   ".join(cells))
    print()
    for line in lines:
        print(line)


def replay(log: list[tuple[str, Any]], tracker: str) -> list[float]:
    """Per-step CPU seconds of ``tracker`` on a recorded episode (resets with the recorded elements; no hook)."""
    import cv2

    cv2.setNumThreads(1)
    tr = perception.make_tracker(TrackerConfig.from_name(tracker))
    times: list[float] = []
    for kind, item in log:
        if kind == "reset":
            obs, elements = item
            tr.reset(obs, elements)
        else:
            t0 = time.thread_time()
            tr.step(item)
            times.append(time.thread_time() - t0)
    return times


def speed(runs: int) -> list[str]:
    """The demo episode's frames through ``depth`` and ``lk`` (reference), ``runs`` interleaved replays."""
    rec, sc = run_episode("depth", "demo", 0, record=True)
    n_el = max((len(item[1]) for k, item in sc.log if k == "reset"), default=0)
    steps = sum(k == "step" for k, _ in sc.log)
    outcome = "success" if rec["success"] else "failure"
    print(f"\nspeed: demo episode (stack-in-order p=0.3 seed 10, depth tracker, {outcome}), {steps} frames of "
          f"2 x 320x240 views, up to {n_el} elements; {runs} replays each, one thread; step time = the thread's "
          "CPU time (this machine is shared: wall-clock times include waiting for a core)")
    med: dict[str, list[float]] = {"depth": [], "lk": []}
    p95: dict[str, list[float]] = {"depth": [], "lk": []}
    for _ in range(runs):
        for name in ("depth", "lk"):
            t = np.asarray(replay(sc.log, name)) * 1e3
            med[name].append(float(np.median(t)))
            p95[name].append(float(np.percentile(t, 95)))
    d, lk = float(np.median(med["depth"])), float(np.median(med["lk"]))
    dp, lkp = float(np.median(p95["depth"])), float(np.median(p95["lk"]))
    print(f"  depth: step median {d:.2f} ms, p95 {dp:.2f} ms; lk: median {lk:.2f} ms, p95 {lkp:.2f} ms")
    return [f"track_step_median: {d:.2f} ms", f"track_step_p95: {dp:.2f} ms", f"lk_step_median: {lk:.2f} ms",
            f"lk_step_p95: {lkp:.2f} ms", f"depth_over_lk_median: {d / max(lk, 1e-9):.2f} x"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trackers", default="lk,depth,sim")
    ap.add_argument("--conditions", default=",".join(CONDITIONS))
    ap.add_argument("--seeds", type=int, default=1, help="episodes per condition and tracker")
    ap.add_argument("--out", type=Path, default=Path("runs/tracking.jsonl"), help="per-episode records (resumed)")
    ap.add_argument("--runs", type=int, default=5, help="replays per tracker for the speed lines")
    ap.add_argument("--skip-accuracy", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    args = ap.parse_args(argv)
    trackers = [t for t in args.trackers.split(",") if t]
    speed_lines = [] if args.skip_speed else speed(max(3, args.runs))
    if not args.skip_accuracy:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        records = [json.loads(x) for x in args.out.read_text().splitlines() if x.strip()] if args.out.exists() else []
        done = {(r["tracker"], r["condition"], r["seed"]) for r in records}
        for seed in range(args.seeds):
            for cid in [c for c in args.conditions.split(",") if c]:
                for tr in trackers:
                    if (tr, cid, seed) in done:
                        continue
                    try:
                        rec, _ = run_episode(tr, cid, seed)
                    except Exception as exc:  # one broken episode (a sandbox that would not start) is reported
                        print(f"{cid} seed {seed} {tr}: ERROR {type(exc).__name__}: {exc}", flush=True)
                        continue  # not recorded: the next run retries it
                    records.append(rec)
                    with args.out.open("a") as fh:
                        fh.write(json.dumps(rec) + "\n")
                    print(f"{cid} seed {seed} {tr}: {'success' if rec['success'] else 'failure'}, "
                          f"{rec['frames']} element-frames, {rec['wall_s']} s", flush=True)
        want = {c for c in args.conditions.split(",") if c}
        report([r for r in records if r["condition"] in want and r["seed"] < args.seeds and r["tracker"] in trackers],
               trackers)
    for line in speed_lines:
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
