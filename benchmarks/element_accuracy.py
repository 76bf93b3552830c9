"""Benchmark: how close the painter's elements are to the objects they stand for, on simulator frames.

Perception: the ``sim`` segmenter (ground-truth masks, the analogue of the paper's ConSeg) and the painter's
geometry on rendered depth; no tracker (every element is built from scratch on the frame). Planner: none (the
task's scripted plan drives the scenes). Ground truth (the scorer only; the painter never reads it): a part's
true centre is the centre of the bounding box of its visual shapes in its link frame, a line's true direction
that box's longest axis, a surface's true normal its thinnest axis (:mod:`code_as_monitor.bench.element_truth`).

Scenes: for every task and seed, the scene after reset ("scattered"), then the undisturbed scripted plan with a
snapshot every ``--every`` seconds of sim time during each action ("during_<skill>": held, carried, pushed) and at
its end ("after_<skill>": placed, stacked, inserted, poured); for stack-in-order also a tower built perfectly
centred (each block's centre exactly above the one below, same yaw), whose pairs give "centred pair" offsets.
Each scene is rendered from four cameras, 320x240: the default front and top views, and two shoulder views the
tests never use (eyes at (0.3, +-0.5, 0.75) m looking at the table centre (0.3, 0, 0), 60 degree field of view).
View sets: ``default`` (the task's own cameras: front + top for the paper's tasks; front, two shoulders and wrist for
the RLBench-style ones), ``shoulders`` (both added shoulder views), ``front`` (the front view alone); each with
clean depth and with 2 mm Gaussian depth noise.

Printed: per task, scene group, view set and noise the point error median / max (mm, 3-D distance to the true
centre), line direction and surface normal error median / max (degrees), line axis and surface plane offsets
(mm), the elements that no view saw and the parts no view saw (the painter then builds the whole object's
element, which is not scored against the part); then per task and element; then overall per view set; the
worst point-like errors from two views (which element, scene and views); the centred pairs' horizontal offsets;
whether the painter knows which elements are off (large errors it flagged weak or gave a matching uncertainty, and
the errors of the elements it calls sound); and machine-readable ``name: value unit`` lines for the two-view
targets (points median <= 3 mm and max <= 8 mm, directions <= 2 degrees, centred pairs <= 5 mm) and for the front
view alone.

Run: ``nice -n 10 .venv/bin/python benchmarks/element_accuracy.py [--seeds 5] [--every 2.0] [--tasks ...]
[--records FILE.jsonl]``; ``--records`` also writes every scored element (one JSON line each, in a fixed order) for
``benchmarks/compare_elements.py``, which pairs two such files element by element (two painter versions).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np

from code_as_monitor.bench.element_truth import PartTruth, element_errors, part_truth
from code_as_monitor.core import Constraint, ElementSpec, Observation, Phase, Subgoal, View
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.planning import ConstraintGenerator, legend_specs
from code_as_monitor.sim.cameras import SimCamera, shoulder_cameras
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.tasks import task_names
from code_as_monitor.vlm.backend import VLMBackendConfig, make_backend

W, H = 320, 240
SHOULDERS = tuple(shoulder_cameras(W, H))
VIEW_SETS = {"default": ("front", "top"), "shoulders": ("shoulder_left", "shoulder_right"), "front": ("front",)}
NOISES_MM = (0.0, 2.0)
TWO_VIEW_SETS = ("default", "shoulders")
MAX_SNAPSHOTS_PER_ACTION = 3
MAX_SUBGOALS = 30


def task_specs(env) -> list[ElementSpec]:
    """The elements the kb's monitors use for ``env``'s task: the parts of every constraint of the kb's plan for
    the task's instruction when each subgoal succeeds (the kb is the rule-based stand-in for the VLM, planning
    from the instruction and the scene's object names as the agent does), in first-use order, less the robot's
    (built from forward kinematics, not from masks)."""
    gen = ConstraintGenerator(make_backend(VLMBackendConfig.from_name("kb")))
    objects = env.world.observe(render=False).objects
    specs: dict[tuple[str, str, str], ElementSpec] = {}
    previous = None
    for _ in range(MAX_SUBGOALS):
        sg = gen.next_subgoal(env.instruction, {}, objects, previous, None)
        if sg.done:
            break
        for s in legend_specs(sg):
            if s.obj != "robot":
                specs.setdefault((s.obj, s.part, s.kind.value), s)
        previous = sg
    return list(specs.values())


@dataclass
class Scene:
    """One rendered moment: views by camera name and the true box of every spec."""

    task: str
    seed: int
    label: str
    views: dict[str, View]
    truth: dict[int, PartTruth]
    specs: list[ElementSpec]
    pairs: list[tuple[int, int]] = field(default_factory=list)  # (lower, upper) spec indices of centred towers
    default: tuple[str, ...] = VIEW_SETS["default"]  # the task's own cameras

    def view_sets(self) -> dict[str, tuple[str, ...]]:
        """View set name -> camera names for this scene (``default`` is the task's own cameras)."""
        return {**VIEW_SETS, "default": self.default}


def _render(world, cams: list[SimCamera]) -> dict[str, View]:
    labels = world.seg_labels()
    return {c.spec.name: c.render(labels) for c in cams}


def _scene(task: str, seed: int, label: str, world, cams, specs, pairs=()) -> Scene:
    truth = {i: part_truth(world, s.obj, s.part) for i, s in enumerate(specs)}
    return Scene(task, seed, label, _render(world, cams), truth, specs, list(pairs),
                 tuple(c.spec.name for c in world.cameras))


def _centred_tower(env, cams, specs, seed: int) -> Scene:
    """Stack the blocks perfectly centred (same x, y and yaw as the lowest one) and render without settling."""
    import pybullet as pb

    w = env.world
    blocks = {s.obj: i for i, s in enumerate(specs) if s.obj.endswith("_block") and not s.part}
    names = [n for n in w.objects if n in blocks]  # bottom to top in the world's object order
    base = w.objects[names[0]].bodies[0]
    pos, orn = pb.getBasePositionAndOrientation(base, physicsClientId=w.client)
    size = part_truth(w, names[0]).extent[2]
    for k, n in enumerate(names):
        pb.resetBasePositionAndOrientation(w.objects[n].bodies[0], [pos[0], pos[1], size / 2 + k * size], orn,
                                           physicsClientId=w.client)
    return _scene("stack-in-order", seed, "centred_tower", w, cams, specs,
                  pairs=[(blocks[lo], blocks[hi]) for lo, hi in pairwise(names)])


def task_scenes(task: str, seed: int, every: float) -> list[Scene]:
    """The scenes of one task and seed (see the module docstring)."""
    with make_env(task, seed=seed, disturbed=False) as env:
        w = env.world
        cams = [*w.cameras, *(SimCamera(s, w.client, w.renderer) for s in SHOULDERS)]
        specs = task_specs(env)
        out = [_scene(task, seed, "scattered", w, cams, specs)]
        for action in env.plan:
            env.policy.start(action)
            next_t, shots = w.t + every, 0
            while not env.policy.done and w.t < env.task.config.time_limit:
                env.policy.step()
                if w.t >= next_t and shots < MAX_SNAPSHOTS_PER_ACTION:
                    out.append(_scene(task, seed, f"during_{action.skill}", w, cams, specs))
                    next_t, shots = w.t + every, shots + 1
            out.append(_scene(task, seed, f"after_{action.skill}", w, cams, specs))
        if task == "stack-in-order":
            out.append(_centred_tower(env, cams, specs, seed))
    return out


def _noisy(views: dict[str, View], names, sigma_mm: float, rng: np.random.Generator) -> dict[str, View]:
    out = {}
    for n in names:
        v = views[n]
        d = v.depth
        if sigma_mm > 0:
            d = d.astype(np.float64)
            ok = d > 0
            d[ok] += rng.normal(0.0, sigma_mm / 1000.0, size=int(ok.sum()))
            d = d.astype(np.float32)
        out[n] = View(v.rgb, d, v.camera, v.seg, v.seg_labels)
    return out


@dataclass
class Record:
    task: str
    label: str
    views: str
    noise: float
    kind: str
    errors: dict[str, float] | None  # None: missing, or its part unseen (the whole object stood in)
    part_unseen: bool = False
    name: str = ""
    weak: bool = False  # the painter's own verdict on the element (ElementSupport.weak)
    uncertainty: float = 0.0  # m, ElementSupport.uncertainty (how far its assumed sides let the centre lie)


def evaluate(scenes: list[Scene], painter: Painter) -> tuple[list[Record], dict[tuple[str, float], list[float]],
                                                              list[float]]:
    """Paint every scene with every view set and noise; the records, centred-pair offsets (m) per
    (view set, noise), and the paint times (s)."""
    records: list[Record] = []
    pairs: dict[tuple[str, float], list[float]] = defaultdict(list)
    times: list[float] = []
    for si, sc in enumerate(scenes):
        sub = Subgoal("look", [Constraint("look", "see every element", Phase.UPON, list(sc.specs))])
        for vs, names in sc.view_sets().items():
            for noise in NOISES_MM:
                rng = np.random.default_rng([si, int(noise * 10), len(names), sc.seed])
                obs = Observation(0.0, _noisy(sc.views, names, noise, rng))
                res = painter.paint(obs, sub)
                times.append(res.seconds)
                by_id = {e.id: e for e in res.elements}
                for i, spec in enumerate(sc.specs):
                    e = by_id.get(i)
                    unseen = e is not None and e.support is not None and not e.support.part_seen
                    err = None if e is None or unseen else element_errors(spec.kind, e.points, sc.truth[i])
                    sup = e.support if e is not None else None
                    records.append(Record(sc.task, sc.label, vs, noise, spec.kind.value, err, unseen,
                                          f"{spec.obj}/{spec.part or '*'}", sup is not None and sup.weak(),
                                          sup.uncertainty if sup is not None else 0.0))
                for lo, hi in sc.pairs:
                    if lo in by_id and hi in by_id:
                        d = by_id[hi].points[0, :2] - by_id[lo].points[0, :2]
                        pairs[(vs, noise)].append(float(np.linalg.norm(d)))
    return records, pairs, times


def _summary(recs: list[Record]) -> dict[str, tuple[float, float, int]]:
    """metric -> (median, max, n) in mm or degrees."""
    vals: dict[str, list[float]] = defaultdict(list)
    for r in recs:
        if r.errors is None:
            continue
        for k, v in r.errors.items():
            vals[k].append(v if k.endswith("_deg") else 1000.0 * v)
    return {k: (float(np.median(v)), float(np.max(v)), len(v)) for k, v in vals.items()}


ORDER = ("point", "axis_offset", "centre", "plane_offset", "direction_deg", "normal_deg")
UNIT = {"point": "mm", "axis_offset": "mm", "centre": "mm", "plane_offset": "mm", "direction_deg": "deg",
        "normal_deg": "deg"}


def _missing(recs: list[Record]) -> str:
    """Counts of elements no view saw and of parts no view saw (their whole object stood in; not scored)."""
    miss = sum(r.errors is None and not r.part_unseen for r in recs)
    unseen = sum(r.part_unseen for r in recs)
    return (f"  missing {miss}/{len(recs)}" if miss else "") + (f"  part unseen {unseen}/{len(recs)}" if unseen else "")


def _fmt(s: dict[str, tuple[float, float, int]]) -> str:
    return "  ".join(f"{k.replace('_deg', '')} {s[k][0]:.1f}/{s[k][1]:.1f} {UNIT[k]} (n={s[k][2]})"
                     for k in ORDER if k in s)


LARGE_MM = 8.0
"""A point-like error above the two-view point target (mm): an element a check should not trust as it is."""


def _point_like_mm(r: Record) -> float:
    return 1000.0 * max(v for k, v in r.errors.items() if not k.endswith("_deg"))


def _sound(r: Record) -> bool:
    return not r.weak and 1000.0 * r.uncertainty < LARGE_MM


def self_knowledge(records: list[Record]) -> tuple[int, int, dict[str, tuple[float, float, int]], int, int, int]:
    """Whether the painter knows which elements are off: among scored elements with a point-like error over
    ``LARGE_MM``, how many it flagged weak or gave an uncertainty of at least half the error (n flagged, n large);
    the summary over the elements it calls sound (not weak, uncertainty under ``LARGE_MM``); and what the flags cost:
    among the elements within ``LARGE_MM``, how many it does not call sound, and how many of those only for their
    uncertainty (n unsound, n unsound by uncertainty alone, n small)."""
    scored = [r for r in records if r.errors is not None]
    large = [r for r in scored if _point_like_mm(r) > LARGE_MM]
    flagged = [r for r in large if r.weak or 1000.0 * r.uncertainty >= 0.5 * _point_like_mm(r)]
    small = [r for r in scored if _point_like_mm(r) <= LARGE_MM]
    unsound = [r for r in small if not _sound(r)]
    return (len(flagged), len(large), _summary([r for r in scored if _sound(r)]), len(unsound),
            sum(not r.weak for r in unsound), len(small))


LARGE_DEG = 10.0
"""A direction or normal error (degrees) past which a check reading the element's direction should not trust it."""


def _angle_deg(r: Record) -> float:
    return max((v for k, v in r.errors.items() if k.endswith("_deg")), default=0.0)


def direction_knowledge(records: list[Record]) -> tuple[int, int, float, list[tuple[str, str]]]:
    """The same for directions: among scored lines and surfaces with a direction or normal error over ``LARGE_DEG``,
    how many the painter flagged weak (n flagged, n large), the largest error of those it calls sound, and the
    (task, element) names of the large ones it did not flag."""
    scored = [r for r in records if r.errors is not None and any(k.endswith("_deg") for k in r.errors)]
    large = [r for r in scored if _angle_deg(r) > LARGE_DEG]
    sound = [_angle_deg(r) for r in scored if not r.weak]
    unflagged = sorted({(r.task, r.name) for r in large if not r.weak})
    return sum(r.weak for r in large), len(large), max(sound, default=float("nan")), unflagged


def write_records(path: str, records: list[Record]) -> None:
    """One JSON line per record, in evaluation order (the same scenes, views and noise draws for the same ``--seeds``,
    ``--every`` and ``--tasks``): errors in metres and degrees as :func:`element_errors` gives them."""
    import json

    with open(path, "w") as f:
        for i, r in enumerate(records):
            f.write(json.dumps({"i": i, "task": r.task, "label": r.label, "views": r.views, "noise": r.noise,
                                "kind": r.kind, "name": r.name, "errors": r.errors, "part_unseen": r.part_unseen,
                                "weak": r.weak, "uncertainty": r.uncertainty}) + "\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds per task (>= 1; the issue asks for >= 5)")
    ap.add_argument("--every", type=float, default=2.0, help="sim seconds between snapshots during an action")
    ap.add_argument("--tasks", nargs="*", default=None, help="tasks (default: every registered task)")
    ap.add_argument("--records", default=None, help="also write every element's record here (JSON lines)")
    args = ap.parse_args(argv)
    tasks = args.tasks or task_names()
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    t0 = time.perf_counter()
    scenes = []
    for t in tasks:
        for s in range(args.seeds):
            scenes += task_scenes(t, s, args.every)
        print(f"[{time.perf_counter() - t0:6.0f} s] scenes of {t}: {len(scenes)} so far", file=sys.stderr, flush=True)
    t_scenes = time.perf_counter() - t0
    records, pairs, times = evaluate(scenes, painter)
    if args.records:
        write_records(args.records, records)
    print(f"perception: sim segmenter masks + painter geometry (no tracker); planner: none (scripted plan); "
          f"{len(scenes)} scenes from {len(tasks)} tasks x {args.seeds} seeds (rendered in {t_scenes:.0f} s); "
          f"cameras {W}x{H}")
    print("per case: median/max; points, offsets in mm (3-D), directions and normals in degrees")
    groups: dict[tuple, list[Record]] = defaultdict(list)
    for r in records:
        groups[(r.task, r.label, r.views, r.noise)].append(r)
    for key in sorted(groups):
        recs = groups[key]
        task, label, vs, noise = key
        print(f"  {task:<18} {label:<22} {vs:<9} noise {noise:.0f} mm: {_fmt(_summary(recs))}{_missing(recs)}")
    print("per task and element (all scenes):")
    by_el: dict[tuple, list[Record]] = defaultdict(list)
    for r in records:
        by_el[(r.task, r.name, r.views)].append(r)
    for key in sorted(by_el):
        recs = by_el[key]
        print(f"  {key[0]:<18} {key[1]:<24} {key[2]:<9}: {_fmt(_summary(recs))}{_missing(recs)}")
    print("overall per view set (all tasks and scenes):")
    overall: dict[tuple[str, float], dict] = {}
    for vs in VIEW_SETS:
        for noise in NOISES_MM:
            recs = [r for r in records if r.views == vs and r.noise == noise]
            overall[(vs, noise)] = s = _summary(recs)
            print(f"  {vs:<9} noise {noise:.0f} mm: {_fmt(s)}{_missing(recs)}")
    worst = sorted((r for r in records if r.views in TWO_VIEW_SETS and r.errors is not None),
                   key=lambda r: -max(v for k, v in r.errors.items() if not k.endswith("_deg")))[:12]
    print("worst point-like errors from two views (point, axis offset, surface centre; mm):")
    for r in worst:
        e = max(v for k, v in r.errors.items() if not k.endswith("_deg"))
        print(f"  {1000 * e:6.1f}  {r.task:<18} {r.name:<24} {r.label:<22} {r.views:<9} noise {r.noise:.0f} mm")
    print("centred pairs (horizontal offset read between two perfectly centred stacked blocks, mm):")
    for (vs, noise), v in sorted(pairs.items()):
        a = 1000.0 * np.asarray(v)
        print(f"  {vs:<9} noise {noise:.0f} mm: median {np.median(a):.1f}, max {a.max():.1f} (n={len(a)})")
    print(f"paint time per scene and view set: median {1000 * np.median(times):.0f} ms")
    print(f"does the painter know? point-like errors over {LARGE_MM:.0f} mm flagged weak (ElementSupport.weak) or with "
          f"an uncertainty of at least half the error; and the elements it calls sound (not weak, uncertainty under "
          f"{LARGE_MM:.0f} mm):")
    knows: dict[str, tuple[int, int, dict, int, int, int]] = {}
    dknows: dict[str, tuple[int, int, float, list[tuple[str, str]]]] = {}
    for tag, sets in (("two_view", TWO_VIEW_SETS), ("front_only", ("front",))):
        knows[tag] = k = self_knowledge([r for r in records if r.views in sets])
        unflagged = sorted({(r.task, r.name) for r in records if r.views in sets and r.errors is not None
                            and _point_like_mm(r) > LARGE_MM and not r.weak
                            and 1000.0 * r.uncertainty < 0.5 * _point_like_mm(r)})
        print(f"  {tag:<10}: {k[0]}/{k[1]} large errors flagged; sound elements: {_fmt(k[2])}")
        print(f"             errors within {LARGE_MM:.0f} mm the painter does not call sound: {k[3]}/{k[5]} "
              f"({k[4]} of them for their uncertainty alone, not weak)")
        if unflagged:
            print(f"             large and not flagged: {', '.join(f'{t} {n}' for t, n in unflagged)}")
        dknows[tag] = dk = direction_knowledge([r for r in records if r.views in sets])
        print(f"  {tag:<10}: directions and normals over {LARGE_DEG:.0f} deg flagged weak: {dk[0]}/{dk[1]}; "
              f"the largest the painter calls sound: {dk[2]:.1f} deg")
        if dk[3]:
            print(f"             over {LARGE_DEG:.0f} deg and not flagged: {', '.join(f'{t} {n}' for t, n in dk[3])}")

    def agg(sets, metric: str, stat: int) -> float:
        vals = [overall[(vs, n)][metric][stat] for vs in sets for n in NOISES_MM if metric in overall[(vs, n)]]
        return max(vals) if vals else float("nan")

    def pair_max(sets) -> float:
        v = [x for vs in sets for n in NOISES_MM for x in pairs.get((vs, n), [])]
        return 1000.0 * max(v) if v else float("nan")

    for tag, sets in (("two_view", TWO_VIEW_SETS), ("front_only", ("front",))):
        print(f"{tag}_point_median_worst: {agg(sets, 'point', 0):.2f} mm")
        print(f"{tag}_point_max: {agg(sets, 'point', 1):.2f} mm")
        print(f"{tag}_direction_max: {agg(sets, 'direction_deg', 1):.2f} deg")
        print(f"{tag}_normal_max: {agg(sets, 'normal_deg', 1):.2f} deg")
        print(f"{tag}_centred_pair_max: {pair_max(sets):.2f} mm")
        flagged, large, sound, unsound, _, small = knows[tag]
        print(f"{tag}_large_errors_flagged: {flagged}/{large} count")
        print(f"{tag}_small_errors_unsound: {unsound}/{small} count")
        print(f"{tag}_sound_point_max: {sound['point'][1] if 'point' in sound else float('nan'):.2f} mm")
        print(f"{tag}_large_directions_flagged: {dknows[tag][0]}/{dknows[tag][1]} count")
        print(f"{tag}_sound_direction_max: {dknows[tag][2]:.2f} deg")
    return 0


if __name__ == "__main__":
    sys.exit(main())
