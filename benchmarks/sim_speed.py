"""Simulator speed: sim-seconds per wall-second for stack-in-order with two 320x240 views at 10 Hz,
and the render time per view for each available renderer.

    .venv/bin/python benchmarks/sim_speed.py [--runs 3]

Ends with one line per figure: ``name: value unit``.
"""

from __future__ import annotations

import argparse
import statistics
import time

from code_as_monitor.sim import WorldConfig, make_env


def episode_factor(render: bool, seed: int) -> float:
    """Sim-seconds per wall-second of one undisturbed open-loop stack-in-order episode."""
    env = make_env("stack-in-order", seed=seed, world_config=WorldConfig(width=320, height=240, camera_hz=10.0))
    w = env.world
    t0 = time.perf_counter()
    w.observe(render=render)
    for action in env.plan:
        env.policy.start(action)
        while not env.policy.done:
            env.policy.step()
            if w.frame_due():
                w.observe(render=render)
    wall = time.perf_counter() - t0
    sim = w.t
    env.close()
    return sim / wall


def render_ms(renderer: str, n: int) -> tuple[str, float] | None:
    """(actual renderer, median ms per 320x240 view) or None when ``renderer`` is unavailable."""
    env = make_env("stack-in-order", seed=0, world_config=WorldConfig(renderer=renderer))
    try:
        if env.world.renderer != renderer:
            return None
        labels = env.world.seg_labels()
        times = []
        for cam in env.world.cameras:
            cam.render(labels)
            for _ in range(n):
                t0 = time.perf_counter()
                cam.render(labels)
                times.append((time.perf_counter() - t0) * 1000)
        return renderer, statistics.median(times)
    finally:
        env.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="episodes per figure (median reported)")
    ap.add_argument("--renders", type=int, default=15, help="renders per view per renderer")
    args = ap.parse_args()
    figures: list[tuple[str, float, str]] = []
    for render in (True, False):
        vals = [episode_factor(render, seed) for seed in range(args.runs)]
        label = "sim_realtime_factor" if render else "sim_realtime_factor_no_render"
        print(f"{label}: runs {[round(v, 2) for v in vals]}")
        figures.append((label, statistics.median(vals), "x"))
    for renderer in ("tiny", "egl"):
        r = render_ms(renderer, args.renders)
        if r is None:
            print(f"renderer {renderer}: not available")
            continue
        figures.append((f"render_{renderer}_320x240", r[1], "ms"))
    for name, value, unit in figures:
        print(f"{name}: {value:.2f} {unit}")


if __name__ == "__main__":
    main()
