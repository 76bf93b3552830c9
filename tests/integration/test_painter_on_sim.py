"""The painter's elements on simulator frames match ground-truth object positions (issue: monitor)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core import Constraint, ElementSpec, Phase, Subgoal
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig

BLOCKS = ("red_block", "green_block", "blue_block")


@pytest.mark.parametrize("seed", [0, 3])
def test_block_elements_match_ground_truth_within_1cm(seed: int) -> None:
    with make_env("stack-in-order", seed=seed, world_config=WorldConfig(width=320, height=240)) as env:
        obs = env.world.observe()
    specs = [ElementSpec(f"{b} top", b, "top") for b in BLOCKS] + [ElementSpec(b, b, "") for b in BLOCKS]
    subgoal = Subgoal("look", [Constraint("look", "see the blocks", Phase.UPON, specs)])
    result = Painter(make_segmenter(SegmenterConfig.from_name("sim"))).paint(obs, subgoal)
    assert not result.missing
    assert {v.shape for v in result.images.values()} == {(240, 320, 3)}
    for el in result.elements:
        obj, part = el.owner
        if part:  # the top face's point: 3-D distance to the top link's pose
            truth = obs.object_poses[f"{obj}/{part}"][:3, 3]
            assert np.linalg.norm(el.points[0] - truth) < 0.01, (el.name, el.points[0], truth)
        else:  # the whole block's point lies on its visible surface: horizontally within 1 cm of the centre
            truth = obs.object_poses[obj][:3, 3]
            assert np.linalg.norm(el.points[0, :2] - truth[:2]) < 0.01, (el.name, el.points[0], truth)
            assert 0.0 < el.points[0, 2] < 0.045
