"""Rendering only what is read: deferred views equal eager renders, are guarded against a moved world,
are counted, survive pickling and counterfactual snapshots; the hull robot visual."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from code_as_monitor.core.errors import ConfigError, SimError
from code_as_monitor.core.observation import View
from code_as_monitor.sim import WorldConfig, make_env
from code_as_monitor.sim.cameras import DeferredView
from code_as_monitor.sim.robot import panda_urdf


def _step(env, n: int) -> None:
    for _ in range(n):
        env.policy.step()


@pytest.fixture()
def env():
    e = make_env("stack-in-order", seed=4, world_config=WorldConfig(defer_render=True))
    e.policy.start(e.plan[0])
    _step(e, 12)  # the arm is moving into the workspace
    yield e
    e.close()


def test_observe_is_eager_unless_the_world_defers():
    e = make_env("stack-in-order", seed=4, disturbed=False)
    try:
        assert not any(isinstance(v, DeferredView) for v in e.world.observe().views.values())
        assert e.world.frames_rendered == 2
        assert all(isinstance(v, DeferredView) for v in e.world.observe(eager=False).views.values())
    finally:
        e.close()


def test_deferred_views_render_on_read_and_equal_an_eager_render(env):
    w = env.world
    obs = w.observe()
    assert all(isinstance(v, DeferredView) and not v.rendered for v in obs.views.values())
    assert w.frames_rendered == 0
    top = obs.views["top"]
    assert top.camera.width == 320 and w.frames_rendered == 0  # the camera model costs no render
    cam = next(c for c in w.cameras if c.spec.name == "top")
    direct = cam.render(w.seg_labels())  # SimCamera.render: an eager render outside the world's cache
    assert w.frames_rendered == 1
    np.testing.assert_array_equal(top.rgb, direct.rgb)
    np.testing.assert_array_equal(top.depth, direct.depth)
    np.testing.assert_array_equal(top.seg, direct.seg)
    assert w.frames_rendered == 2  # only the view that was read; once
    _ = top.rgb, top.depth, top.seg
    assert w.frames_rendered == 2 and not obs.views["front"].rendered
    assert top.mask_of("red_block").any()


def test_reading_a_deferred_view_after_the_world_moved_raises(env):
    w = env.world
    obs = w.observe()
    front = obs.views["front"]
    _ = front.rgb  # read in time: kept
    _step(env, 1)
    assert front.rgb.shape == (240, 320, 3)
    with pytest.raises(SimError, match="top"):
        _ = obs.views["top"].depth


def test_pickling_a_deferred_view_gives_a_plain_view(env):
    v = env.world.observe().views["front"]
    back = pickle.loads(pickle.dumps(v))
    assert type(back) is View
    np.testing.assert_array_equal(back.rgb, v.rgb)


def test_save_state_renders_the_current_views_first(env):
    """A counterfactual rollout moves the world and rewinds it: views of the instant it started from
    are rendered before it, so they show that instant."""
    w = env.world
    obs = w.observe()
    reference = w.render()["front"].rgb
    token = w.save_state()
    assert all(v.rendered for v in obs.views.values())
    _step(env, 20)
    w.restore_state(token)
    np.testing.assert_array_equal(obs.views["front"].rgb, reference)


@pytest.mark.parametrize("visual", ["hull", "decimated"])
def test_a_cheaper_robot_visual_renders_the_same_scene(visual):
    with pytest.raises(ConfigError, match="robot_visual"):
        WorldConfig(robot_visual="wireframe")
    assert panda_urdf(visual) == panda_urdf(visual)  # cached once
    mesh = make_env("stack-in-order", seed=4, disturbed=False, world_config=WorldConfig(robot_visual="mesh"))
    hull = make_env("stack-in-order", seed=4, disturbed=False, world_config=WorldConfig(robot_visual=visual))
    try:
        a, b = mesh.world.observe().views["top"], hull.world.observe().views["top"]
        for name in ("red_block", "green_block", "blue_block"):
            np.testing.assert_array_equal(a.mask_of(name), b.mask_of(name))
        assert b.mask_of("robot").any()
        assert np.allclose(mesh.world.robot.joints(), hull.world.robot.joints())
    finally:
        mesh.close()
        hull.close()


def test_one_instant_is_rendered_once_and_any_motion_renders_anew(env):
    import pybullet as pb

    w = env.world
    first = w.observe(eager=True)
    again = w.observe(eager=True)  # the same tick, nothing moved: the same images, copies
    assert w.frames_rendered == 2
    np.testing.assert_array_equal(first.views["top"].rgb, again.views["top"].rgb)
    again.views["top"].rgb[:] = 0  # a consumer that writes into its copy changes no one else's
    assert w.observe().views["top"].rgb.any() and w.frames_rendered == 2
    body = w.body_of("red_block")  # moved without a tick (a script teleporting an object)
    pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=w.client)
    pb.resetBasePositionAndOrientation(body, [pos[0] + 0.05, pos[1], pos[2]], orn, physicsClientId=w.client)
    moved = w.observe(eager=True)
    assert w.frames_rendered == 4
    assert not np.array_equal(moved.views["top"].seg, first.views["top"].seg)
    _step(env, 1)
    w.observe(eager=True)
    assert w.frames_rendered == 6


def test_the_decimated_arm_looks_like_the_full_one_mid_pick():
    """The same instants drawn with the full and the decimated meshes: the arm's outline moves by under a pixel
    (measured: 0.6 % of the arm's pixels change label; the collision-mesh hull changes 10 %) and its colours stay
    (mean absolute RGB difference on the arm about 3 of 255; the hull's 25)."""
    envs = {v: make_env("stack-in-order", seed=0, disturbed=False, world_config=WorldConfig(robot_visual=v))
            for v in ("mesh", "decimated")}
    try:
        changed, arm_px, rgb = 0, 0, []
        for e in envs.values():
            e.policy.start(e.plan[0])
        for k in range(1, 121):
            for e in envs.values():
                e.policy.step()
            if k % 40:
                continue
            a, b = (envs[v].world.observe(eager=True) for v in ("mesh", "decimated"))
            for name in a.views:
                va, vb = a.views[name], b.views[name]
                ia, ib = va.mask_of("robot"), vb.mask_of("robot")
                changed += int((va.seg != vb.seg).sum())
                arm_px += int((ia | ib).sum())
                both = ia & ib
                rgb.append(np.abs(va.rgb.astype(int) - vb.rgb.astype(int))[both].mean())
        assert arm_px > 0
        assert changed / arm_px < 0.02
        assert float(np.mean(rgb)) < 10.0
    finally:
        for e in envs.values():
            e.close()
