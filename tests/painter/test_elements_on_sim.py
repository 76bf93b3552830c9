"""Each element kind on simulator frames is within the issue's targets (issue 12), from the default views and
from two shoulder views the other tests never use. Thresholds are the targets: points median <= 3 mm and max
<= 8 mm, line directions and surface normals <= 2 degrees, perfectly centred stacked blocks read <= 5 mm apart.
Perception: sim segmenter masks, the painter's geometry (no tracker). Ground truth:
:mod:`code_as_monitor.bench.element_truth`."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.bench.element_truth import element_errors, part_truth
from code_as_monitor.core import Constraint, ElementSpec, Observation, Phase, Subgoal
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.cameras import CameraSpec, SimCamera
from code_as_monitor.sim.env import make_env

POINT_MEDIAN, POINT_MAX, ANGLE_MAX, PAIR_MAX = 0.003, 0.008, 2.0, 0.005
SHOULDERS = [CameraSpec(f"shoulder_{s}", eye=(0.3, y, 0.75), target=(0.3, 0.0, 0.0), fov_y_deg=60.0)
             for s, y in (("left", 0.5), ("right", -0.5))]


def _observe(world, views: str) -> Observation:
    if views == "default":
        return world.observe()
    labels = world.seg_labels()
    cams = [SimCamera(s, world.client, world.renderer) for s in SHOULDERS]
    return Observation(world.t, {c.spec.name: c.render(labels) for c in cams}, world.robot_state())


def _paint(obs: Observation, specs: list[ElementSpec]) -> dict[int, object]:
    res = Painter(make_segmenter(SegmenterConfig.from_name("sim"))).paint(
        obs, Subgoal("look", [Constraint("look", "see", Phase.UPON, specs)]))
    assert not res.missing, res.missing
    return {e.id: e for e in res.elements}


BLOCKS = ("red_block", "green_block", "blue_block")


@pytest.mark.parametrize("views", ["default", "shoulders"])
def test_block_points_are_their_centres_and_a_centred_tower_reads_centred(views: str) -> None:
    import pybullet as pb

    errors, pairs = [], []
    for seed in (0, 1):
        with make_env("stack-in-order", seed=seed, disturbed=False) as env:
            w = env.world
            specs = [ElementSpec(b, b) for b in BLOCKS]
            els = _paint(_observe(w, views), specs)
            errors += [element_errors("point", els[i].points, part_truth(w, b))["point"] for i, b in enumerate(BLOCKS)]
            # a tower built perfectly centred: every block's centre exactly above the lowest one's, same yaw
            pos, orn = pb.getBasePositionAndOrientation(w.objects[BLOCKS[0]].bodies[0], physicsClientId=w.client)
            for k, b in enumerate(BLOCKS):
                pb.resetBasePositionAndOrientation(w.objects[b].bodies[0], [pos[0], pos[1], 0.02 + 0.04 * k], orn,
                                                   physicsClientId=w.client)
            els = _paint(_observe(w, views), specs)
            pairs += [float(np.linalg.norm(els[k + 1].points[0, :2] - els[k].points[0, :2])) for k in range(2)]
            errors += [element_errors("point", els[i].points, part_truth(w, b))["point"] for i, b in enumerate(BLOCKS)]
    assert np.median(errors) <= POINT_MEDIAN and max(errors) <= POINT_MAX, np.round(1000 * np.array(errors), 1)
    assert max(pairs) <= PAIR_MAX, np.round(1000 * np.array(pairs), 1)


@pytest.mark.parametrize("views", ["default", "shoulders"])
@pytest.mark.parametrize(("task", "line", "surface"), [
    ("slot-pen", ("pen", "body"), ("pen_holder", "rim")),
    ("stow-book", ("book", "spine"), ("bookshelf", "slot")),
])
def test_lines_and_surfaces_are_within_2_degrees(views: str, task: str, line: tuple, surface: tuple) -> None:
    with make_env(task, seed=0, disturbed=False) as env:
        w = env.world
        specs = [ElementSpec("line", *line, kind="line"), ElementSpec("surface", *surface, kind="surface")]
        els = _paint(_observe(w, views), specs)
        le = element_errors("line", els[0].points, part_truth(w, *line))
        se = element_errors("surface", els[1].points, part_truth(w, *surface))
    assert le["direction_deg"] <= ANGLE_MAX and se["normal_deg"] <= ANGLE_MAX, (le, se)
    assert le["axis_offset"] <= POINT_MAX and se["plane_offset"] <= POINT_MAX, (le, se)


@pytest.mark.parametrize("views", ["default", "shoulders"])
def test_a_rope_bead_is_painted_at_its_own_centre_or_flagged(views: str) -> None:
    """A rope's bead covers 4-16 pixels a view at 320x240. One that no view sees with ``min_pixels`` is built from
    its own few pixels (a weak element: few points); before, the whole rope's masks stood in for it, which put 4 of
    20 beads of rope seed 1732669626 5-7 cm off, at the rope's centre, and from the shoulder views 26 of 80 beads
    of these seeds 15-136 mm off (the element the coverage check and the trackers then used). Only a bead that no
    view shows with even a quarter of ``min_pixels`` stands on its object's masks, flagged (``part_seen`` False)."""
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    least = max(1, painter.min_pixels // 4)
    own = 0
    for seed in (1732669626, 0, 1, 315323714):
        with make_env("rope-close-square", seed=seed, disturbed=False) as env:
            w = env.world
            beads = sorted(p for p in w.objects["rope"].parts)
            obs = _observe(w, views)
            specs = [ElementSpec(f"rope {b}", "rope", b) for b in beads]
            els = _paint(obs, specs)
            for i, (b, spec) in enumerate(zip(beads, specs)):
                pixels = [int(painter.segmenter.segment(v, spec, spec.name).part_mask.sum())
                          for v in obs.views.values()]
                if els[i].support.part_seen:
                    own += 1
                    err = element_errors("point", els[i].points, part_truth(w, "rope", b))["point"]
                    assert err <= POINT_MAX, (seed, b, err, pixels)
                    if max(pixels) < painter.min_pixels:
                        assert els[i].support.weak(), (seed, b, pixels, els[i].support)
                else:
                    assert max(pixels) < least, f"rope {seed} {b}: painted from the whole rope with {pixels} pixels"
    assert own >= 70, own


def test_a_few_pixels_give_a_point_not_a_direction() -> None:
    """A part no view shows with ``min_pixels`` whose few pixels bound it is painted from them as a point (its centre),
    but not as a line or a surface: a few pixels give no direction (a book's spine seen end-on in the front view alone
    read 90 degrees off); those keep the whole object's stand-in, flagged."""
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    checked = 0
    with make_env("rope-close-square", seed=1732669626, disturbed=False) as env:
        w = env.world
        obs = _observe(w, "shoulders")
        for b in sorted(w.objects["rope"].parts):
            spec = ElementSpec(f"rope {b}", "rope", b)
            pixels = [int(painter.segmenter.segment(v, spec, spec.name).part_mask.sum()) for v in obs.views.values()]
            if max(pixels) >= painter.min_pixels or sum(pixels) >= painter.min_pixels or max(pixels) < 3:
                continue  # only beads its views show with a few pixels (a quarter of min_pixels or more in one)
            point = _paint(obs, [spec])[0]
            line = _paint(obs, [ElementSpec(f"rope {b}", "rope", b, kind="line")])[0]
            assert point.support.part_seen and point.support.weak(), (b, pixels)
            assert not line.support.part_seen, (b, pixels)
            checked += 1
    assert checked >= 3, checked
