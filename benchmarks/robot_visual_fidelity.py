"""Benchmark: how the cheaper arm visuals look and cost against the full meshes, at the same instants.

For each task, two worlds of the same seed step the same open-loop plan: one draws the arm with its full detailed
meshes (``mesh``), the other with ``--visual`` (``decimated``, the default of ``cam bench``/``cam run``, or
``hull``); the physics is the same (checked: the joints agree). Every ``--every`` control steps both render every
view, and per view:

- the share of the arm's pixels (in either image) whose segmentation label differs: the outline moved;
- the mean absolute RGB difference (0-255) on pixels that are the arm in both;
- whether any pixel off the arm (in both) differs in depth: objects seen around the arm must be untouched;
- CPU milliseconds of the render, both ways (``time.process_time``, median).

Run: ``.venv/bin/python benchmarks/robot_visual_fidelity.py [--visual decimated] [--tasks ...] [--steps 400]``.
The last lines read ``name: value unit``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from code_as_monitor.sim import WorldConfig, make_env

TASKS = ("stack-in-order", "sweep-half", "rope-close-square", "stow-book", "open-drawer")


def _frames(visual: str, task: str, seed: int, steps: int, every: int) -> tuple[list, list[float], list]:
    """(per frame: per view (rgb, depth, seg, arm mask)), render CPU ms per view, joints per frame."""
    env = make_env(task, seed=seed, world_config=WorldConfig(width=320, height=240, robot_visual=visual),
                   disturbed=False)
    w = env.world
    frames, ms, joints, k = [], [], [], 0
    try:
        for action in env.plan:
            env.policy.start(action)
            while not env.policy.done and k < steps:
                env.policy.step()
                k += 1
                if k % every == 0:
                    t0 = time.process_time()
                    obs = w.observe(render=True, eager=True)
                    ms.append((time.process_time() - t0) * 1e3 / len(obs.views))
                    frames.append([(v.rgb, v.depth, v.seg, v.mask_of("robot")) for v in obs.views.values()])
                    joints.append(np.asarray(w.robot.joints()))
            if k >= steps:
                break
    finally:
        env.close()
    return frames, ms, joints


def compare(visual: str, task: str, seed: int, steps: int, every: int) -> dict[str, float]:
    a, ms_a, ja = _frames("mesh", task, seed, steps, every)
    b, ms_b, jb = _frames(visual, task, seed, steps, every)
    if not all(np.allclose(x, y) for x, y in zip(ja, jb, strict=True)):
        raise SystemExit(f"{task}: the two worlds' joints differ: not the same physics")
    changed = arm = 0
    rgb: list[float] = []
    off_arm_depth = 0
    for fa, fb in zip(a, b, strict=True):
        for (ra, da, sa, ia), (rb, db, sb, ib) in zip(fa, fb, strict=True):
            changed += int((sa != sb).sum())
            arm += int((ia | ib).sum())
            both = ia & ib
            if both.any():
                rgb.append(float(np.abs(ra.astype(int) - rb.astype(int))[both].mean()))
            off_arm_depth += int((da != db)[~ia & ~ib].sum())
    return {"arm_pixels_changed_pct": 100.0 * changed / max(arm, 1), "rgb_on_arm": float(np.mean(rgb)) if rgb else 0.0,
            "off_arm_depth_changed": float(off_arm_depth), "render_mesh_ms": statistics.median(ms_a),
            "render_visual_ms": statistics.median(ms_b), "views": float(sum(len(f) for f in a))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--visual", default="decimated", help="decimated (default) or hull, against mesh")
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--steps", type=int, default=400, help="control steps per task")
    ap.add_argument("--every", type=int, default=40, help="render every this many control steps")
    args = ap.parse_args()
    rows = {}
    for task in [t for t in args.tasks.split(",") if t]:
        r = rows[task] = compare(args.visual, task, args.seed, args.steps, args.every)
        print(f"{task:18s} views {r['views']:.0f}: arm pixels changed {r['arm_pixels_changed_pct']:.2f} %, RGB on the "
              f"arm {r['rgb_on_arm']:.1f}, off-arm depth pixels changed {r['off_arm_depth_changed']:.0f}, render "
              f"{r['render_mesh_ms']:.1f} -> {r['render_visual_ms']:.1f} ms")
    v = args.visual
    print(f"{v}_arm_pixels_changed_max: {max(r['arm_pixels_changed_pct'] for r in rows.values()):.2f} %")
    med = statistics.median(r["arm_pixels_changed_pct"] for r in rows.values())
    print(f"{v}_arm_pixels_changed_median: {med:.2f} %")
    print(f"{v}_rgb_on_arm_median: {statistics.median(r['rgb_on_arm'] for r in rows.values()):.1f} of 255")
    print(f"{v}_off_arm_depth_pixels_changed: {sum(r['off_arm_depth_changed'] for r in rows.values()):.0f} px")
    ratio = statistics.median(r["render_visual_ms"] / r["render_mesh_ms"] for r in rows.values())
    print(f"{v}_render_ratio_vs_mesh: {ratio:.2f} x")


if __name__ == "__main__":
    main()
