"""Per-frame cost of the lk tracker: two 640x480 RGB-D views, 8 elements (14 tracked points + a tip).

Measures ``LKTracker.step`` only (grayscale conversion, LK forward + backward per view, depth checks,
lifting with ``geometry.backproject_pixels``, fusion, rigid fits, re-seeding), not the rendering.
Frames come from the analytic renderer of the perception tests (textured blocks on a textured table,
moving a few millimetres per frame), played back and forth so that few frames need rendering.

Run: ``.venv/bin/python benchmarks/tracking.py [--frames 60] [--warmup 5]``. Prints lines such as
``track_step_median: 2.9 ms``. Budget context: a whole monitor step (tracking + sandbox evaluation)
should stay within 10 ms, so tracking should stay within about 7 ms.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "perception"))

from perception_synth import Box, Scene, observe, two_cameras

from code_as_monitor.core.elements import Element
from code_as_monitor.perception.trackers.base import TrackerConfig, make_tracker


def _scene() -> Scene:
    cols = [(200, 40, 40), (40, 160, 60), (40, 60, 200), (220, 180, 40)]
    xy = [(-0.06, -0.06), (0.06, -0.06), (-0.06, 0.06), (0.06, 0.06)]
    return Scene([
        Box(f"block_{i}", np.array([x, y, 0.025]), np.array([0.05, 0.05, 0.05]), color=c, texture_seed=i + 1)
        for i, ((x, y), c) in enumerate(zip(xy, cols))
    ])


def _elements(scene: Scene) -> list[Element]:
    els: list[Element] = []
    for i, b in enumerate(scene.boxes):  # 4 points: top centres
        els.append(Element.point(i, f"{b.name} top", b.center + np.array([0, 0, 0.025]), owner=(b.name, "top")))
    for i, b in enumerate(scene.boxes[:2]):  # 2 surfaces x 4 points: top faces, inset 1 cm
        q = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * 0.015
        top = np.c_[b.center[:2] + q, np.full(4, 0.05)]
        els.append(Element.surface(4 + i, f"{b.name} top face", top, owner=(b.name, "top")))
    b = scene.boxes[2]  # 1 line x 2 points along a top face
    ends = b.center + np.array([[-0.015, 0, 0.025], [0.015, 0, 0.025]])
    els.append(Element.line(6, f"{b.name} axis", ends[0], ends[1], owner=(b.name, "")))
    els.append(Element.point(7, "tip", np.array([0.0, 0.0, 0.25]), owner=("robot", "tip")))
    return els


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60, help="timed frames (>= 30)")
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--distinct", type=int, default=10, help="distinct rendered frames (played back and forth)")
    args = ap.parse_args(argv)

    cams = two_cameras(640, 480)
    scene = _scene()
    base = [b.center.copy() for b in scene.boxes]
    v = np.array([0.003, 0.002, 0.0])
    frames = []
    for f in range(args.distinct):
        for b, c in zip(scene.boxes, base):
            b.center = c + f * v
        frames.append(observe(scene, cams, 0.0, tip=np.array([0.0, 0.002 * f, 0.25])))
    order = list(range(args.distinct)) + list(range(args.distinct - 2, 0, -1))

    for b, c in zip(scene.boxes, base):
        b.center = c
    tracker = make_tracker(TrackerConfig.from_name("lk"))
    tracker.reset(frames[0], _elements(scene))
    n_points = sum(len(e.points) for e in _elements(scene) if e.owner[0] != "robot")
    times, stale = [], 0
    for k in range(args.warmup + args.frames):
        obs = frames[order[(k + 1) % len(order)]]
        obs.t = 0.1 * (k + 1)
        t0 = time.perf_counter()
        res = tracker.step(obs)
        dt = time.perf_counter() - t0
        if k >= args.warmup:
            times.append(dt)
            stale += sum(int(s.sum()) for s in res.stale.values())
    ms = np.array(times) * 1e3
    print(f"views: 2 x {cams[0].width}x{cams[0].height}, elements: {len(_elements(scene))}, tracked points: {n_points}")
    print(f"frames_timed: {len(ms)}")
    print(f"track_step_median: {np.median(ms):.2f} ms")
    print(f"track_step_p90: {np.percentile(ms, 90):.2f} ms")
    print(f"track_step_max: {ms.max():.2f} ms")
    print(f"stale_point_frames: {stale}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
