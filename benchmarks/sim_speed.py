"""Simulator speed: sim-seconds per wall-second for stack-in-order with two 320x240 views at 10 Hz,
and the render time per view for each renderer, robot visual, image size and segmentation flag.

    .venv/bin/python benchmarks/sim_speed.py [--runs 3] [--renders 15]

The episode figures: every frame's views rendered (``observe(eager=True)``, what a tracker that reads
every frame costs), the views observed but never read (deferred views: no render, what the ``sim``
tracker costs) and no views at all. The render figures are CPU milliseconds per 320x240 view (median),
so other load on a shared machine inflates them less than wall time; each set is measured in the same
process and the ratios are against ``tiny`` with the detailed robot mesh, the whole scene in one render. The
``backdrop`` figures are the world's default (``WorldConfig.backdrop``): the table rendered once per view and
composed under a render of the rest (``sim.backdrop``, the same pixels). Ends with one line per
figure: ``name: value unit``.
"""

from __future__ import annotations

import argparse
import statistics
import time

from code_as_monitor.sim import WorldConfig, make_env


def episode_factor(mode: str, seed: int, robot_visual: str = "mesh", backdrop: bool = False) -> float:
    """Sim-seconds per wall-second of one undisturbed open-loop stack-in-order episode; ``mode``:
    ``eager`` (render every frame), ``deferred`` (observe, read no image) or ``none`` (no views);
    ``backdrop``: the table composed from its own render (``sim.backdrop``, the default of ``WorldConfig``)."""
    cfg = WorldConfig(width=320, height=240, camera_hz=10.0, robot_visual=robot_visual, backdrop=backdrop)
    env = make_env("stack-in-order", seed=seed, world_config=cfg, disturbed=False)
    w = env.world

    def observe() -> None:
        w.observe(render=mode != "none", eager=mode == "eager")

    t0 = time.perf_counter()
    observe()
    for action in env.plan:
        env.policy.start(action)
        while not env.policy.done:
            env.policy.step()
            if w.frame_due():
                observe()
    wall = time.perf_counter() - t0
    sim = w.t
    env.close()
    return sim / wall


def render_ms(renderer: str, n: int, robot_visual: str = "mesh", size: tuple[int, int] = (320, 240),
              seg: bool = True, backdrop: bool = False) -> float | None:
    """Median CPU ms per view of the stack scene (arm in view, mid-pick), or None when ``renderer`` is
    unavailable. ``seg=False`` asks PyBullet for no segmentation mask. ``backdrop``: the view as the world gives
    it with the table composed from its own cached render (``SimCamera.images``: the scene's render without the
    table, the composition and the conversion to depth); otherwise one ``getCameraImage`` of the whole scene."""
    import pybullet as pb

    cfg = WorldConfig(renderer=renderer, width=size[0], height=size[1], robot_visual=robot_visual,
                      backdrop=backdrop)
    env = make_env("stack-in-order", seed=0, world_config=cfg, disturbed=False)
    try:
        if env.world.renderer != renderer:
            return None
        env.policy.start(env.plan[0])
        for _ in range(30):  # the arm reaches into the workspace
            env.policy.step()
        r = pb.ER_BULLET_HARDWARE_OPENGL if renderer == "egl" else pb.ER_TINY_RENDERER
        flags = pb.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX if seg else pb.ER_NO_SEGMENTATION_MASK
        times = []
        for cam in env.world.cameras:
            s = cam.spec
            args = dict(width=s.width, height=s.height, viewMatrix=cam._view, projectionMatrix=cam._proj,
                        renderer=r, flags=flags, shadow=0, physicsClientId=env.world.client)
            def once() -> None:
                if backdrop:
                    cam.images(cam._view)  # noqa: B023  (called in this iteration only)
                else:
                    pb.getCameraImage(**args)  # noqa: B023

            once()  # a backdrop's first render of this view is cached from here on
            for _ in range(n):
                t0 = time.process_time()
                once()
                times.append((time.process_time() - t0) * 1000)
        return statistics.median(times)
    finally:
        env.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="episodes per figure (median reported)")
    ap.add_argument("--renders", type=int, default=15, help="renders per view per configuration")
    args = ap.parse_args()
    figures: list[tuple[str, float, str]] = []
    for label, mode, visual in (("sim_realtime_factor", "eager", "mesh"),
                                ("sim_realtime_factor_decimated", "eager", "decimated"),
                                ("sim_realtime_factor_hull", "eager", "hull"),
                                ("sim_realtime_factor_decimated_backdrop", "eager", "decimated+backdrop"),
                                ("sim_realtime_factor_deferred", "deferred", "mesh"),
                                ("sim_realtime_factor_no_render", "none", "mesh")):
        vis, _, bd = visual.partition("+")
        vals = [episode_factor(mode, seed, vis, bd == "backdrop") for seed in range(args.runs)]
        print(f"{label}: runs {[round(v, 2) for v in vals]}")
        figures.append((label, statistics.median(vals), "x"))
    ref = render_ms("tiny", args.renders)
    assert ref is not None
    figures.append(("render_tiny_320x240", ref, "ms"))
    for name, kw in (("render_tiny_decimated_320x240", {"robot_visual": "decimated"}),
                     ("render_tiny_hull_320x240", {"robot_visual": "hull"}),
                     ("render_tiny_backdrop_320x240", {"backdrop": True}),
                     ("render_tiny_decimated_backdrop_320x240", {"robot_visual": "decimated", "backdrop": True}),
                     ("render_tiny_noseg_320x240", {"seg": False}),
                     ("render_tiny_640x480", {"size": (640, 480)}),
                     ("render_tiny_160x120", {"size": (160, 120)}),
                     ("render_egl_320x240", {"renderer": "egl"})):
        kw = dict(kw)
        ms = render_ms(str(kw.pop("renderer", "tiny")), args.renders, **kw)  # type: ignore[arg-type]
        if ms is None:
            print(f"{name}: renderer not available")
            continue
        figures.append((name, ms, "ms"))
        figures.append((name.replace("render_", "render_ratio_"), ms / ref, "x"))
    for name, value, unit in figures:
        print(f"{name}: {value:.2f} {unit}")


if __name__ == "__main__":
    main()
