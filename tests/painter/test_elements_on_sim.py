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
