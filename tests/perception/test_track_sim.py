from __future__ import annotations

import numpy as np
import pytest
from perception_synth import Box, Scene, observe, two_cameras

from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import PerceptionError
from code_as_monitor.perception.trackers.base import TrackerConfig, make_tracker


def _rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def test_sim_tracker_exact_under_rigid_motion():
    cams = two_cameras()
    scene = Scene([Box("red_block", np.array([0.0, 0.0, 0.03]), np.array([0.06, 0.06, 0.06]))])
    obs = observe(scene, cams, 0.0, tip=np.array([0.0, 0.0, 0.2]))
    top = np.array([[-0.02, -0.02, 0.06], [0.02, -0.02, 0.06], [0.02, 0.02, 0.06]])
    elements = [
        Element.surface(0, "red top", top, owner=("red_block", "top")),
        Element.point(1, "red", np.array([0.0, 0.0, 0.03]), owner=("red_block", "")),
        Element.point(2, "tip", np.array([0.0, 0.0, 0.2]), owner=("robot", "tip")),
    ]
    tr = make_tracker(TrackerConfig.from_name("sim"))
    tr.reset(obs, elements)
    # Move the block (translate + yaw) and the tip; the oracle must follow exactly.
    R, dt = _rot_z(0.3), np.array([0.05, -0.02, 0.01])
    poses = scene.poses()
    for key in ("red_block", "red_block/top"):
        T = poses[key].copy()
        T[:3, :3] = R
        T[:3, 3] += dt
        poses[key] = T
    obs.object_poses = poses
    obs.robot.ee_points["tip"] = np.array([0.1, 0.0, 0.25])
    res = tr.step(obs)
    centre0 = np.array([0.0, 0.0, 0.06])
    expect_top = (top - centre0) @ R.T + centre0 + dt
    np.testing.assert_allclose(res.points[0], expect_top, atol=1e-12)
    np.testing.assert_allclose(res.points[1], np.array([[0.0, 0.0, 0.03]]) + dt, atol=1e-12)
    np.testing.assert_allclose(res.points[2], [[0.1, 0.0, 0.25]], atol=1e-12)
    assert not any(s.any() for s in res.stale.values())
    assert res.visible_views[0] == 2
    assert all(res.support[i] == float("inf") for i in (0, 1, 2))  # exact motion: it adds no error to a paint


def test_sim_tracker_needs_poses():
    cams = two_cameras()
    scene = Scene([Box("red_block", np.array([0.0, 0.0, 0.03]), np.array([0.06, 0.06, 0.06]))])
    obs = observe(scene, cams, 0.0, with_poses=False)
    tr = make_tracker(TrackerConfig.from_name("sim"))
    with pytest.raises(PerceptionError, match="lk tracker"):
        tr.reset(obs, [Element.point(0, "red", np.zeros(3), owner=("red_block", ""))])


def test_sim_tracker_unknown_owner():
    cams = two_cameras()
    obs = observe(Scene([]), cams, 0.0)
    tr = make_tracker(TrackerConfig.from_name("sim"))
    with pytest.raises(PerceptionError, match="teapot"):
        tr.reset(obs, [Element.point(0, "t", np.zeros(3), owner=("teapot", "spout"))])
