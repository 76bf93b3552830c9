"""RLBench's four cameras: the wrist camera's extrinsics follow the hand every frame and match its rendering;
mount settings are validated."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.geometry import backproject_mask
from code_as_monitor.sim.cameras import CameraSpec, SimCamera, rlbench_cameras
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig


@pytest.mark.parametrize("defer", [False, True])
def test_wrist_camera_follows_the_hand_and_matches_its_rendering(defer: bool) -> None:
    cfg = WorldConfig(width=160, height=120, defer_render=defer)  # deferred: pose fixed when observed
    with make_env("screw-bulb", seed=0, noise=0.0, world_config=cfg) as env:
        w, pol = env.world, env.policy
        before = w.observe().views["wrist"].camera.T_world_cam
        pol.start(env.plan[0])
        for _ in range(70):  # on the way down to the bulb
            pol.step()
        obs = w.observe()
        wrist = obs.views["wrist"]
        T = wrist.camera.T_world_cam
        assert np.linalg.norm(T[:3, 3] - before[:3, 3]) > 0.1  # it moved with the arm
        cam = next(c for c in w.cameras if c.spec.name == "wrist")
        assert np.allclose(T, w.robot.grasp_pose() @ cam._T_mount_cam, atol=1e-6)
        assert np.allclose(obs.views["front"].camera.T_world_cam, w.camera_models()["front"].T_world_cam)
        # the bulb's pixels, lifted with the wrist camera's depth and pose, lie on the bulb
        mask = wrist.mask_of("lamp", "bulb")
        assert mask.sum() > 50
        pts = backproject_mask(mask, wrist.depth, wrist.camera)
        ball = w.pose("lamp/bulb")[:3, 3] + np.array([0.0, 0.0, 0.022])
        r = np.linalg.norm(pts - ball, axis=1)
        assert abs(float(np.median(r)) - 0.025) < 0.003  # on the 2.5 cm ball's surface
        assert np.percentile(r, 90) < 0.03  # (silhouette pixels mix depths)


def test_the_four_views_and_mount_validation() -> None:
    specs = rlbench_cameras(64, 48)
    assert [s.name for s in specs] == ["front", "left_shoulder", "right_shoulder", "wrist"]
    assert [s.mount for s in specs] == ["world", "world", "world", "wrist"]
    with pytest.raises(ConfigError, match="mount"):
        CameraSpec("x", eye=(0, 0, 1), target=(0, 0, 0), mount="elbow")
    with pytest.raises(ConfigError, match="mount_pose"):
        SimCamera(specs[3], client=0)  # a wrist camera needs its mount's pose
