"""The painter fills each element's cloud, object cloud and support from simulator frames (issue 12)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core import Constraint, ElementSpec, Phase, Subgoal
from code_as_monitor.core.elements import MAX_CLOUD_POINTS
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig


@pytest.fixture(scope="module")
def stack_obs():
    with make_env("stack-in-order", seed=1, world_config=WorldConfig(width=320, height=240)) as env:
        return env.world.observe()


def _inside_box(P: np.ndarray, T: np.ndarray, half: np.ndarray, tol: float = 0.004) -> np.ndarray:
    local = (P - T[:3, 3]) @ T[:3, :3]
    return np.all(np.abs(local) <= half + tol, axis=1)


def test_clouds_lie_on_their_part_and_object(stack_obs) -> None:
    specs = [ElementSpec("red top", "red_block", "top", "surface"), ElementSpec("green", "green_block", "", "point"),
             ElementSpec("tip", "robot", "tip", "point")]
    res = Painter(make_segmenter(SegmenterConfig.from_name("sim"))).paint(
        stack_obs, Subgoal("look", [Constraint("look", "see", Phase.UPON, specs)]))
    assert not res.missing
    top, green, tip = res.elements
    assert tip.cloud is None and tip.object_cloud is None and tip.support is None
    T_red, T_green = stack_obs.object_poses["red_block"], stack_obs.object_poses["green_block"]
    block_half = np.full(3, 0.02)
    # the top part's cloud: on the 5 mm top slab; its object cloud: the whole red block, larger
    T_top = stack_obs.object_poses["red_block/top"]
    assert _inside_box(top.cloud, T_top, np.array([0.02, 0.02, 0.0025])).mean() > 0.98
    assert _inside_box(top.object_cloud, T_red, block_half).mean() > 0.98
    assert len(top.object_cloud) > len(top.cloud)
    assert green.object_cloud is green.cloud
    assert _inside_box(green.cloud, T_green, block_half).mean() > 0.98
    for el in (top, green):
        assert 20 <= len(el.cloud) <= MAX_CLOUD_POINTS
        assert el.support.views == 2 and el.support.points >= len(el.cloud)
        assert np.isfinite(el.support.residual) and max(el.support.extent) < 0.07
        d = el.to_dict()
        assert d["cloud_points"] == len(el.cloud) and d["support"]["points"] == el.support.points


def test_big_parts_are_capped() -> None:
    from code_as_monitor.geometry import cap_cloud

    P = np.random.default_rng(0).uniform(-0.5, 0.5, size=(20000, 3)) * np.array([1.0, 1.0, 0.0])
    C = cap_cloud(P, 500)
    assert 100 < len(C) <= 500
    assert np.allclose(C.min(axis=0)[:2], -0.5, atol=0.1) and np.allclose(C.max(axis=0)[:2], 0.5, atol=0.1)
    assert cap_cloud(P[:10], 500).shape == (10, 3)
