"""World contract: observation shapes/frames, seg labels and parts, cameras in the OpenCV convention."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.observation import Observation
from code_as_monitor.sim import WorldConfig, make_env
from code_as_monitor.sim.cameras import CameraSpec, decode_seg_id, encode_seg_id


@pytest.fixture(scope="module")
def stack_obs():
    env = make_env("stack-in-order", seed=0)
    yield env, env.world.observe()
    env.close()


def test_observation_contract(stack_obs):
    _, obs = stack_obs
    assert isinstance(obs, Observation)
    assert set(obs.views) == {"front", "top"}
    for v in obs.views.values():
        assert v.rgb.dtype == np.uint8 and v.rgb.shape == (240, 320, 3)
        assert v.depth.dtype == np.float32 and v.seg.dtype == np.int32
        assert v.camera.width == 320 and v.camera.height == 240
    assert {"red_block", "green_block", "blue_block", "table"} <= set(obs.objects)
    assert obs.robot.ee_kind == "suction" and obs.robot.gripper == 0.0
    assert obs.robot.ee_pose.shape == (4, 4) and obs.robot.ee_points["tip"].shape == (3,)
    assert np.allclose(obs.robot.ee_pose[:3, 2], [0, 0, -1], atol=0.05)  # tool points down
    for key in ("red_block", "red_block/top", "red_block/body"):
        assert obs.object_poses[key].shape == (4, 4)
    assert obs.object_poses["red_block/top"][2, 3] > obs.object_poses["red_block"][2, 3]


def test_part_masks_exist_in_top_view(stack_obs):
    _, obs = stack_obs
    top = obs.views["top"]
    for name in ("red_block", "green_block", "blue_block"):
        assert top.mask_of(name, "top").sum() > 10, name
    labels = set(top.seg_labels.values())
    assert ("table", "") in labels and ("robot", "suction") in labels and ("robot", "panda_hand") in labels


@pytest.mark.parametrize("view", ["front", "top"])
def test_camera_model_matches_rendering(stack_obs, view):
    """Projecting a block top's centre with the exported CameraModel hits that block's pixels, and the
    depth there equals the point's z in the camera frame."""
    _, obs = stack_obs
    v = obs.views[view]
    for name in ("red_block", "green_block", "blue_block"):
        p = obs.object_poses[name][:3, 3] + np.array([0, 0, 0.02])
        uv, z = v.camera.project(p[None])
        u, r = np.round(uv[0]).astype(int)
        if not (0 <= u < 320 and 0 <= r < 240) or not v.mask_of(name).any():
            continue  # occluded or out of view
        obj, _ = v.seg_labels[int(v.seg[r, u])]
        assert obj == name
        assert abs(float(v.depth[r, u]) - z[0]) < 0.01


def test_seg_id_roundtrip():
    assert decode_seg_id(encode_seg_id(5, 3)) == (5, 3)
    assert decode_seg_id(encode_seg_id(7, -1)) == (7, -1)


def test_configurable_cameras_and_independent_clients():
    cams = [CameraSpec("side", eye=(0.5, 0.8, 0.5), target=(0.5, 0.0, 0.0), width=64, height=48)]
    a = make_env("stack-in-order", seed=1, world_config=WorldConfig(cameras=cams))
    b = make_env("stack-in-order", seed=2)
    try:
        assert a.world.client != b.world.client
        obs = a.world.observe()
        assert set(obs.views) == {"side"} and obs.views["side"].rgb.shape == (48, 64, 3)
        assert not np.allclose(a.world.position("red_block"), b.world.position("red_block"))
    finally:
        a.close()
        b.close()


def test_frame_schedule_and_clock():
    env = make_env("stack-in-order", seed=0, world_config=WorldConfig(control_hz=40, camera_hz=10))
    try:
        w = env.world
        assert w.frame_due()
        w.observe(render=False)  # the frame at t = 0
        frames = 0
        for _ in range(40):
            env.policy.step()
            if w.frame_due():
                w.observe(render=False)
                frames += 1
        assert w.t == pytest.approx(1.0) and frames == 10
    finally:
        env.close()


def test_save_restore_state_rewinds():
    env = make_env("stack-in-order", seed=0)
    try:
        w = env.world
        token = w.save_state()
        before = w.position("green_block")
        env.policy.start(env.plan[0])
        while not env.policy.done:
            env.policy.step()
        assert w.robot.ee.holding is not None
        w.restore_state(token)
        assert w.t == 0.0 and w.robot.ee.holding is None
        assert np.allclose(w.position("green_block"), before, atol=1e-6)
    finally:
        env.close()
