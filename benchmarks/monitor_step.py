"""Per-frame monitor latency on simulator frames (issue: the monitor and the closed loop).

Records the frames of a pick-and-place in stack-in-order at 640x480 (two views), then, with rendering
outside the timing, measures for the kb's place-on subgoal (green on red):

- monitor step: LK tracking of both views + lifting + fusion + history + every check in the sandbox;
- sandbox round trip alone: ``MonitorRuntime.step`` with fixed inputs;
- painter per subgoal: segment (simulator masks), lift, fuse, fit every element, draw the prompts; the same
  observation painted ``--paint-runs`` times after one warm-up (the table's support plane is found once per
  observation, so it is in the warm-up only), and with a fresh painter each time (the plane found every time,
  as every new subgoal's observation needs it).

References measured in the same run: rendering one frame (both views) with PyBullet's tiny renderer; lifting
both views' whole depth images once (``lift_depth``: what the painter did per subgoal before it lifted only the
masks' pixels).
Targets (2-core machine): monitor step <= 10 ms, sandbox round trip <= 0.3 ms, painter <= 500 ms.

    .venv/bin/python benchmarks/monitor_step.py [--frames 60] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=60, help="frames recorded (default 60)")
    ap.add_argument("--repeats", type=int, default=5, help="passes over the recorded frames (default 5)")
    ap.add_argument("--paint-runs", type=int, default=15, help="timed painter runs (default 15)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    from code_as_monitor.core import Action
    from code_as_monitor.geometry import lift_depth
    from code_as_monitor.monitor.runtime import MonitorRuntime
    from code_as_monitor.painter import Painter
    from code_as_monitor.perception import ElementHistory, SegmenterConfig, TrackerConfig, make_segmenter, make_tracker
    from code_as_monitor.planning.coder import MonitorCoder
    from code_as_monitor.planning.generator import ConstraintGenerator
    from code_as_monitor.sim.env import make_env
    from code_as_monitor.sim.world import WorldConfig
    from code_as_monitor.vlm import KBBackendConfig, make_backend

    backend = make_backend(KBBackendConfig())
    gen = ConstraintGenerator(backend)
    coder = MonitorCoder(backend, usage=gen.usage)
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))

    with make_env("stack-in-order", seed=args.seed, world_config=WorldConfig(width=640, height=480), p=0.0) as env:
        world, policy = env.world, env.policy
        policy.start(Action("pick", {"obj": "green_block"}))
        while not policy.done:
            policy.step()
        obs0 = world.observe()
        pick = gen.next_subgoal(env.instruction, {}, obs0.objects, None, None)
        subgoal = gen.next_subgoal(env.instruction, {}, obs0.objects, pick, "success")
        assert subgoal.action is not None and subgoal.action.skill == "place_on", subgoal.text

        painted = painter.paint(obs0, subgoal)  # warm-up: imports, ray caches, the support plane
        paint_ms, fresh_ms, lift_ms = [], [], []
        for _ in range(max(3, args.paint_runs)):
            t0 = time.perf_counter()
            painted = painter.paint(obs0, subgoal)
            paint_ms.append((time.perf_counter() - t0) * 1e3)
            t0 = time.perf_counter()
            Painter(painter.segmenter).paint(obs0, subgoal)
            fresh_ms.append((time.perf_counter() - t0) * 1e3)
            t0 = time.perf_counter()
            for v in obs0.views.values():
                lift_depth(v.depth, v.camera)
            lift_ms.append((time.perf_counter() - t0) * 1e3)
        elements = painted.elements
        positions = {e.id: e.points for e in elements}

        # Record the frames of the placement (rendering timed separately, as the reference).
        frames, render_ms = [], []
        policy.start(subgoal.action)
        while len(frames) < args.frames and not policy.done:
            policy.step()
            if world.frame_due():
                t0 = time.perf_counter()
                frames.append(world.observe())
                render_ms.append((time.perf_counter() - t0) * 1e3)

    with MonitorRuntime() as runtime:
        hist = ElementHistory(64)
        hist.push(obs0.t, positions)
        source = coder.write_program(subgoal, elements, painted.images,
                                     check=lambda src: runtime.start(src, subgoal.constraints, positions,
                                                                     *hist.arrays(), obs0.t))
        step_ms: list[float] = []
        for _ in range(args.repeats):
            tracker = make_tracker(TrackerConfig.from_name("lk"))
            tracker.reset(obs0, elements)
            hist = ElementHistory(64)
            hist.push(obs0.t, positions)
            for obs in frames:
                t0 = time.perf_counter()
                tr = tracker.step(obs)
                hist.push(obs.t, tr.points)
                H, ht = hist.arrays()
                runtime.step(tr.points, H, ht, obs.t)
                step_ms.append((time.perf_counter() - t0) * 1e3)
        H, ht = hist.arrays()
        pts = {i: p[-1] for i, p in H.items()}
        for _ in range(200):
            runtime.step(pts, H, ht, 1.0)
        rt_ms = []
        for _ in range(3000):
            t0 = time.perf_counter()
            runtime.step(pts, H, ht, 1.0)
            rt_ms.append((time.perf_counter() - t0) * 1e3)

    med = statistics.median
    print(f"subgoal: {subgoal.text!r}; {len(elements)} elements, {len(subgoal.constraints)} checks, "
          f"{len(frames)} frames x {args.repeats} passes, 640x480 x 2 views; program {len(source)} chars")
    print(f"monitor step: median {med(step_ms):.2f} ms, p90 {np.percentile(step_ms, 90):.2f} ms, "
          f"max {max(step_ms):.2f} ms")
    print(f"reference: rendering one frame (2 views) {med(render_ms):.1f} ms; "
          f"monitor step / render = {med(step_ms) / med(render_ms):.3f}")
    print(f"sandbox round trip: median {med(rt_ms):.3f} ms, p99 {np.percentile(rt_ms, 99):.3f} ms")
    print(f"painter per subgoal: median {med(paint_ms):.1f} ms over {len(paint_ms)} runs "
          f"({len(painted.elements)} elements); with the support plane found each time {med(fresh_ms):.1f} ms; "
          f"reference: lifting both whole views {med(lift_ms):.1f} ms")
    print(f"monitor_step_median: {med(step_ms):.2f} ms")
    print(f"sandbox_roundtrip_median: {med(rt_ms):.3f} ms")
    print(f"painter_per_subgoal_median: {med(paint_ms):.1f} ms")
    print(f"painter_per_subgoal_with_support_plane_median: {med(fresh_ms):.1f} ms")
    print(f"lift_both_views_reference_median: {med(lift_ms):.1f} ms")
    print(f"render_frame_reference_median: {med(render_ms):.1f} ms")


if __name__ == "__main__":
    main()
