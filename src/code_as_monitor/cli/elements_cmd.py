"""``cam elements``: run the element pipeline on the synthetic scene and compare with ground truth.

The scene (``code_as_monitor.geometry.synthetic``): a box, a tilted plate and a tilted rod on a table,
seen by two 640x480 RGB-D cameras; depth is ray-cast analytically, then corrupted with Gaussian
noise and outlier pixels. Each standard element (box top as a point and as a surface, the plate's
surface, the rod's axis) is built from the two views and printed next to the truth with its error.
"""

from __future__ import annotations

import argparse

from code_as_monitor.cli import validate as v


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "elements",
        help="build constraint elements on a synthetic RGB-D scene and compare with ground truth",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--seed", type=v.seed, default=0, help="noise seed (default 0)")
    p.add_argument("--noise-mm", type=v.non_negative, default=2.0, help="Gaussian depth noise sigma in mm (default 2)")
    p.add_argument(
        "--outliers", type=v.probability, default=0.01,
        help="fraction of object pixels given a random wrong depth, in [0, 1] (default 0.01)",
    )
    p.set_defaults(func=run)


def _fmt(p) -> str:  # (3,) -> "(+0.012, -0.034, +0.056)"
    return "(" + ", ".join(f"{x:+.3f}" for x in p) + ")"


def run(args: argparse.Namespace) -> int:
    import time

    from code_as_monitor.core.registry import check_positive, check_probability
    from code_as_monitor.geometry import build_element
    from code_as_monitor.geometry.synthetic import STANDARD_SPECS, element_errors, make_scene

    check_positive("elements", "noise-mm", args.noise_mm, allow_zero=True)
    check_probability("elements", "outliers", args.outliers)
    scene = make_scene()
    views = scene.views(seed=args.seed, noise_mm=args.noise_mm, outlier_frac=args.outliers)
    cam = views[0].camera
    print(
        f"synthetic scene: box, plate, rod on a table; {len(views)} views {cam.width}x{cam.height} "
        f"({', '.join(v.camera.name for v in views)}); seed {args.seed}, depth noise {args.noise_mm:g} mm, "
        f"outliers {100 * args.outliers:g} %"
    )
    print("world frame, metres (z up); errors in mm and degrees")
    import scipy.spatial  # noqa: F401  (imported before timing: the pipeline imports them lazily)
    import sklearn.cluster  # noqa: F401

    total_ms = 0.0
    for i, spec in enumerate(STANDARD_SPECS):
        t0 = time.perf_counter()
        e = build_element(i, spec, [(v.mask_of(spec.obj, spec.part), v.depth, v.camera) for v in views])
        total_ms += 1000.0 * (time.perf_counter() - t0)
        truth = scene.truth(spec)
        errs = element_errors(spec.kind, e.points, truth)
        owner = f"{spec.obj}/{spec.part}" if spec.part else spec.obj
        print(f"[{e.id}] {spec.name} ({spec.kind.value}, {owner})")
        for j in range(max(len(e.points), len(truth))):
            est = _fmt(e.points[j]) if j < len(e.points) else "-"
            tru = _fmt(truth[j]) if j < len(truth) else "-"
            print(f"    estimate {est:<26} truth {tru}")
        parts = (f"{k.rsplit('_', 1)[0]} {v:.1f} {k.rsplit('_', 1)[1]}" for k, v in errs.items())
        print("    error    " + ", ".join(parts))
    print(f"built {len(STANDARD_SPECS)} elements in {total_ms:.1f} ms")
    return 0
