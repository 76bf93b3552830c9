"""Benchmark: build constraint elements from RGB-D views.

1. One constraint's three elements from two 640x480 views of the synthetic scene: the box (a point), the
   plate (a surface) and the rod (a line); their masks cover about 5 % of each image; depth carries 2 mm noise
   and 1 % outlier pixels. Timed: back-projection, fusion, downsampling, outlier removal, clustering, the box
   fit and carving of all three (rendering and segmentation are not). Reference, measured in the same run:
   plain back-projection of the same masks alone.
2. The painter on a whole subgoal: sweep-half's 41 elements (the zone's surface and 40 small blocks' points)
   from the simulator's two 320x240 default views, ``sim`` segmenter masks. Timed: ``Painter.paint`` (segment
   every view, lift, fit, draw). Reference in the same run: lifting both views' depth images once.

The machine is shared: compare the ratios, not the absolute times, across runs.
Run: ``.venv/bin/python benchmarks/elements.py [--runs N]``. The last lines are machine-readable:
``elements_build_median: <ms> ms``, ``elements_peak_mem: <MiB> MiB`` and
``painter_per_subgoal_41_median: <ms> ms``.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import sys
import time
import tracemalloc

import numpy as np

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.geometry import backproject_mask, build_element
from code_as_monitor.geometry.synthetic import make_scene

SPECS = (
    ElementSpec("box", "box", "", ElementKind.POINT),
    ElementSpec("plate", "plate", "", ElementKind.SURFACE),
    ElementSpec("rod", "rod", "", ElementKind.LINE),
)


def _median_ms(fn, runs: int, warmup: int = 3) -> float:
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=21, help="timed runs (>= 15)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    runs = max(15, args.runs)

    scene = make_scene(640, 480)
    views = scene.views(seed=args.seed, noise_mm=2.0, outlier_frac=0.01)
    obs = {s.name: [(v.mask_of(s.obj, s.part), v.depth, v.camera) for v in views] for s in SPECS}
    for v in views:
        union = np.logical_or.reduce([v.mask_of(s.obj, s.part) for s in SPECS])
        print(f"view {v.camera.name}: {v.camera.width}x{v.camera.height}, constraint masks cover "
              f"{100 * union.mean():.1f} % ({int(union.sum())} px)")

    def build() -> list:
        return [build_element(i, s, obs[s.name]) for i, s in enumerate(SPECS)]

    def backproject_only() -> list:
        return [backproject_mask(m, d, c) for s in SPECS for m, d, c in obs[s.name]]

    build_ms = _median_ms(build, runs)
    ref_ms = _median_ms(backproject_only, runs)

    tracemalloc.start()
    build()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux, bytes on macOS
    rss_mib = rss / (1024.0 * 1024.0) if sys.platform == "darwin" else rss / 1024.0

    for e in build():
        print(f"  element {e.id} {e.name} ({e.kind.value}): {np.round(e.points, 3).tolist()}")
    print(f"runs: {runs} (after 3 warm-up runs)")
    print(f"reference backproject_only_median: {ref_ms:.2f} ms")
    print(f"ratio build/backproject: {build_ms / ref_ms:.1f}x")
    print(f"process ru_maxrss: {rss_mib:.1f} MiB")
    sub_ms, lift_ms, n_el = _painter_41(max(5, runs // 3))
    print(f"painter: {n_el} elements per subgoal; reference lift_both_views_median: {lift_ms:.2f} ms; "
          f"ratio paint/lift: {sub_ms / lift_ms:.0f}x")
    print(f"elements_build_median: {build_ms:.1f} ms")
    print(f"elements_peak_mem: {peak / (1024.0 * 1024.0):.1f} MiB")
    print(f"painter_per_subgoal_41_median: {sub_ms:.1f} ms")
    return 0


def _painter_41(runs: int) -> tuple[float, float, int]:
    """(paint median ms, lift-both-views median ms, elements) for sweep-half's subgoal on the sim's views."""
    from code_as_monitor.core import Constraint, Subgoal
    from code_as_monitor.geometry import lift_depth
    from code_as_monitor.painter import Painter
    from code_as_monitor.perception import SegmenterConfig, make_segmenter
    from code_as_monitor.sim.env import make_env

    with make_env("sweep-half", seed=0, disturbed=False) as env:
        obs = env.world.observe()
        blocks = [n for n in env.world.objects if n not in ("table", "zone")]
    specs = [ElementSpec("zone", "zone", "surface", ElementKind.SURFACE)] + [ElementSpec(b, b) for b in blocks]
    sub = Subgoal("sweep", [Constraint("in_zone", "blocks in the zone", "upon", specs)])
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    ms = _median_ms(lambda: painter.paint(obs, sub), runs, warmup=1)
    ref = _median_ms(lambda: [lift_depth(v.depth, v.camera) for v in obs.views.values()], runs, warmup=1)
    return ms, ref, len(painter.paint(obs, sub).elements)


if __name__ == "__main__":
    sys.exit(main())
