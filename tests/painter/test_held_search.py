"""The painter's held-object search lifts only the pixels near the tip first (``geometry.occlusion.ball_pixel_box``,
``any_point_near``): on simulator frames it must find exactly the objects the search over every object's whole masks
finds (a block carried by the suction cup, the cup down on a block on the table, a teapot held by its handle)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core import Action, ElementSpec
from code_as_monitor.painter import Painter
from code_as_monitor.painter.painter import HELD_RADIUS, HELD_SIZE
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.env import make_env


def _every_mask(painter: Painter, obs, per_view) -> list[str]:
    """The search as it was: every object's whole masks lifted in every view."""
    out = []
    for name in obs.objects:
        if name == "robot":
            continue
        clouds = [lv.points(painter.segmenter.segment(v, ElementSpec(name, name)).instance_mask)
                  for v, lv, _ in per_view]
        P = np.vstack([c for c in clouds if len(c)] or [np.empty((0, 3))])
        d = np.linalg.norm(P - obs.robot.tip, axis=1)
        if len(P) and d.min() <= HELD_RADIUS and np.percentile(d, 95) <= HELD_SIZE:
            out.append(name)
    return out


def _frames(task: str, action: Action, every: int = 5) -> list:
    """Observations every ``every`` control steps while the policy plays ``action``."""
    with make_env(task, seed=3, disturbed=False) as env:
        env.policy.start(action)
        out, k = [], 0
        while not env.policy.done:
            env.policy.step()
            k += 1
            if k % every == 0:
                out.append(env.world.observe())
    return out


@pytest.mark.parametrize(("task", "action"), [
    ("stack-in-order", Action("pick", {"obj": "green_block"})),
    ("pour-tea", Action("grasp", {"obj": "teapot", "part": "handle"})),
])
def test_the_search_near_the_tip_finds_what_the_whole_masks_find(task: str, action: Action) -> None:
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    frames = [o for o in _frames(task, action) if o.robot is not None and o.robot.gripper >= 0.5]
    assert frames, "no frame with the gripper closed or the suction on"
    found = 0
    for obs in frames:
        per_view = painter._segment_and_lift(obs, [], [])
        held = list(painter._held(obs, per_view))
        assert held == _every_mask(painter, obs, per_view), obs.t
        found += bool(held)
    assert found, "never held: the comparison would be vacuous"
