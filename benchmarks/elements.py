"""Benchmark: build the elements of one constraint from two 640x480 RGB-D views.

The constraint involves the synthetic scene's box (a point), plate (a surface) and rod (a line); their
masks together cover about 5 % of each image. Depth carries 2 mm noise and 1 % outlier pixels.
Timed: back-projection, fusion, downsampling, outlier removal, DBSCAN and fitting of all three
elements (rendering and segmentation are not). Reference, measured in the same run: plain
back-projection of the same masks alone.

Run: ``.venv/bin/python benchmarks/elements.py [--runs N]``. The last two lines are machine-readable:
``elements_build_median: <ms> ms`` and ``elements_peak_mem: <MiB> MiB``.
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
    print(f"elements_build_median: {build_ms:.1f} ms")
    print(f"elements_peak_mem: {peak / (1024.0 * 1024.0):.1f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
