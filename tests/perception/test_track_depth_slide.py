"""The depth tracker on a stick let go into a holder: it slides down its own axis, which seen points cannot tell.

A square stick stands in a square tube (the holder's four walls hide its lower part from both cameras), carried
down by the gripper, then let go: it drops 12 mm further along its own axis. One centimetre higher, its shaft above
the walls is seen as well (and more of it, as less is hidden in the tube); only its top end, where the cameras now
see past it, contradicts that pose. The tracker must follow the slide (``depth_search._rank``): before that ranking
it stopped 8 mm above the true pose (now within 1 mm).
"""

from __future__ import annotations

import numpy as np
from perception_synth import Box, Scene, observe, two_cameras

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.core.observation import Observation, RobotState
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.perception.trackers.base import TrackerConfig, make_tracker

DOWN = np.diag([1.0, -1.0, -1.0])
WALL = 0.008  # m, the tube's wall thickness
INNER = 0.03  # m, the tube's inner width
TUBE_H = 0.07  # m, the tube's height


def _scene(stick_z: float) -> Scene:
    """The stick (1.6 x 1.6 x 14 cm) centred at height ``stick_z`` in the tube at the origin."""
    c = INNER / 2 + WALL / 2
    L = INNER + 2 * WALL
    walls = [Box(f"tube_{i}", np.array(p), np.array(s), color=(90, 90, 90), textured=False) for i, (p, s) in
             enumerate([((c, 0, TUBE_H / 2), (WALL, L, TUBE_H)), ((-c, 0, TUBE_H / 2), (WALL, L, TUBE_H)),
                        ((0, c, TUBE_H / 2), (INNER, WALL, TUBE_H)), ((0, -c, TUBE_H / 2), (INNER, WALL, TUBE_H))])]
    stick = Box("stick", np.array([0.0, 0.0, stick_z]), np.array([0.016, 0.016, 0.14]), color=(30, 160, 60),
                textured=False)
    return Scene([stick, *walls], table_textured=False)


def _obs(scene: Scene, cams, t: float, gripper: float) -> Observation:
    stick = scene.boxes[0]
    tip = np.array([0.0, 0.0, stick.hi[2]]) if gripper else np.array([0.0, 0.0, 0.45])
    obs = observe(scene, cams, t, with_poses=False)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = DOWN, tip
    obs.robot = RobotState(ee_pose=T, gripper=gripper, ee_points={"tip": tip})
    return obs


def test_a_stick_let_go_into_its_holder_is_followed_down_its_own_axis() -> None:
    cams = two_cameras()
    z0 = 0.11  # the stick's centre: its bottom 4 cm above the table, 3 cm inside the tube
    scene = _scene(z0)
    obs0 = _obs(scene, cams, 0.0, 1.0)
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    el = painter.build_element(obs0, 0, ElementSpec("stick", "stick", "", "line"))
    assert el is not None
    tr = make_tracker(TrackerConfig.from_name("depth"))
    tr.reset(obs0, [el])
    z, t = z0, 0.0
    for dz, gripper in [(-0.004, 1.0)] * 3 + [(-0.012, 0.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)]:
        z, t = z + dz, t + 0.1  # carried down 4 mm a frame, then let go: it drops 12 mm at once and rests
        scene.boxes[0].center = np.array([0.0, 0.0, z])
        res = tr.step(_obs(scene, cams, t, gripper))
        truth = el.points + np.array([0.0, 0.0, z - z0])
        assert not res.stale[0].any(), t
        err = float(np.linalg.norm(res.points[0] - truth, axis=1).max())
        assert err < 0.004, (round(t, 1), round(1e3 * err, 1))
