"""The painter's two ablation switches on simulator frames: ORB-keypoint elements (CS off) and unconnected points
(CP off), each through the same ``Painter.paint`` and ``build_element`` the monitor calls."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core import Constraint, ElementKind, ElementSpec, Phase, Subgoal
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig


@pytest.fixture(scope="module")
def pen_obs():
    with make_env("slot-pen", seed=1, world_config=WorldConfig(width=320, height=240)) as env:
        return env.world.observe()


def _subgoal() -> Subgoal:
    parts = [ElementSpec("pen body", "pen", "body", "point"), ElementSpec("pen tip", "pen", "tip", "point"),
             ElementSpec("pen axis", "pen", "", "line"), ElementSpec("holder rim", "pen_holder", "rim", "surface")]
    return Subgoal("insert", [Constraint("c", "the pen goes in", Phase.DURING, parts)])


def _painter(**kw) -> Painter:
    return Painter(make_segmenter(SegmenterConfig.from_name("sim")), **kw)


def _near_object(P: np.ndarray, T: np.ndarray, radius: float) -> bool:
    return bool(np.all(np.linalg.norm(P - T[:3, 3], axis=1) < radius))


def test_keypoint_elements_lie_on_their_object_and_know_no_parts(pen_obs) -> None:
    res = _painter(element_source="orb-keypoints").paint(pen_obs, _subgoal())
    assert not res.missing
    body, tip, axis, rim = res.elements
    assert [e.kind for e in res.elements] == [ElementKind.POINT, ElementKind.POINT, ElementKind.LINE,
                                              ElementKind.SURFACE]
    assert np.allclose(body.points, tip.points), "no part masks: the pen's two point parts are the same element"
    pen, holder = pen_obs.object_poses["pen"], pen_obs.object_poses["pen_holder"]
    assert _near_object(np.vstack([body.points, axis.points, body.cloud]), pen, 0.12)
    assert _near_object(np.vstack([rim.points, rim.cloud]), holder, 0.12)
    masks = _painter().paint(pen_obs, _subgoal())
    assert not np.allclose(masks.elements[0].points, masks.elements[1].points), "part masks tell them apart"


def test_unconnected_points_replace_lines_and_surfaces_and_rebuild_one_by_one(pen_obs) -> None:
    sg = _subgoal()
    painter = _painter(connect_points=False)
    res = painter.paint(pen_obs, sg)
    full = _painter().paint(pen_obs, _subgoal())
    assert all(e.kind is ElementKind.POINT for e in res.elements) and len(res.elements) == 1 + 1 + 2 + 4
    assert np.allclose(np.vstack([e.points for e in res.elements]), np.vstack([e.points for e in full.elements]))
    assert sg.constraints[0].element_ids == list(range(8))
    assert all(p.kind is ElementKind.POINT for p in sg.constraints[0].parts)
    for e in res.elements:  # the re-acquisition and refresh hook gives the same point again
        again = painter.build_element(pen_obs, e.id, res.specs[e.id])
        assert again is not None and again.kind is ElementKind.POINT
        assert np.allclose(again.points, e.points, atol=1e-6), e.name
