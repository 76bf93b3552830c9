"""open-drawer: scene contract (parts and seg labels), success checker, open loop with and without the slip,
the pull physically dragging the drawer, the jaws as proprioceptive points, and config validation."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.episode import run_open_loop
from code_as_monitor.sim.tasks.base import TaskConfig
from code_as_monitor.sim.tasks.open_drawer import OPEN_MIN, drawer_open
from code_as_monitor.sim.world import WorldConfig


@pytest.mark.parametrize(("opening", "held", "ok"), [
    (0.16, False, True),
    (OPEN_MIN, False, True),
    (0.16, True, False),  # still in the gripper
    (0.149, False, False),  # just short
    (0.04, False, False),  # the grasp slipped early
    (0.0, False, False),
])
def test_drawer_open_on_constructed_states(opening: float, held: bool, ok: bool) -> None:
    assert drawer_open(opening, held)[0] is ok


def test_scene_parts_seg_labels_and_reachable_handle() -> None:
    with make_env("open-drawer", seed=3, world_config=WorldConfig(width=160, height=120)) as env:
        w, task = env.world, env.task
        obs = w.observe()
        assert {"drawer_cabinet/frame", "drawer_cabinet/drawer", "drawer_cabinet/handle"} <= set(obs.object_poses)
        labels = set(obs.views["top"].seg_labels.values())
        assert {("drawer_cabinet", "frame"), ("drawer_cabinet", "drawer"), ("drawer_cabinet", "handle")} <= labels
        for part in ("frame", "drawer", "handle"):  # each part is its own mask in the top view
            assert obs.views["top"].mask_of("drawer_cabinet", part).sum() > 10, part
        assert task.opening(w) == pytest.approx(0.0, abs=1e-6)
        handle = w.position("drawer_cabinet/handle")
        assert handle[2] == pytest.approx(0.08, abs=1e-3)
        assert 0.45 < float(np.linalg.norm(handle[:2])) < 0.55
        # the drawer opens towards the robot base (within 35 degrees of straight at it)
        u = task.pull_axis(w, "drawer_cabinet")
        assert float(np.dot(u[:2], -handle[:2] / np.linalg.norm(handle[:2]))) > np.cos(np.radians(36))
        assert {"finger_left", "finger_right", "tip"} <= set(obs.robot.ee_points)
        jaw = np.linalg.norm(obs.robot.ee_points["finger_left"] - obs.robot.ee_points["finger_right"])
        assert jaw == pytest.approx(0.08, abs=0.005)  # open


def test_open_loop_succeeds_undisturbed_and_the_grasp_drags_the_drawer() -> None:
    with make_env("open-drawer", seed=0) as env:
        w, pol, task = env.world, env.policy, env.task
        pol.start(env.plan[0])
        while not pol.done:
            pol.step()
        assert w.robot.ee.holding == w.body_of("drawer_cabinet")
        f = w.robot_state().ee_points
        assert 0.01 < float(np.linalg.norm(f["finger_left"] - f["finger_right"])) < 0.05  # closed on the bar
        assert w.position("drawer_cabinet/handle")[2] == pytest.approx(0.08, abs=2e-3)  # not lifted
        pol.start(env.plan[1])
        lags, q = [], []
        while not pol.done and w.robot.ee.holding is not None:
            pol.step()
            lags.append(float(np.linalg.norm(w.robot.tip() - w.position("drawer_cabinet/handle"))))
            q.append(task.opening(w))
        assert max(lags) < 0.02  # the handle follows the grasp point
        assert np.all(np.diff(q) > -1e-4) and q[-1] > OPEN_MIN
        while not pol.done:
            pol.step()
        w.idle(0.5)
        assert env.evaluate().success, env.evaluate().reason
    res = run_open_loop("open-drawer", seed=1)
    assert res.success, res.reason


def test_open_loop_fails_when_the_grasp_slips() -> None:
    res = run_open_loop("open-drawer", seed=0, disturbance="slip")
    assert not res.success
    slips = [e for e in res.events if e["kind"] == "grasp_slipped"]
    assert len(slips) == 1 and slips[0]["obj"] == "drawer_cabinet"
    assert 0.02 < res.info["opening"] < 0.08  # left where the slip happened (3-7 cm, plus a few mm coasting)


def test_bad_disturbance_is_a_config_error_naming_the_value() -> None:
    with pytest.raises(ConfigError, match="'wobble'"):
        TaskConfig.from_name("open-drawer", disturbance="wobble")
