"""Which view a baseline's single-image question goes to, on camera sets without the paper's view names."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.baselines.vqa_views import HAND_RADIUS, question_view, steepness
from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ObservationError
from code_as_monitor.core.observation import Observation, RobotState, View


def _view(name: str, eye, target=(0.5, 0.0, 0.0)) -> View:
    cam = CameraModel.look_at(name, np.array(eye, float), np.array(target, float), 64, 48, 50.0,
                              up=np.array([0.0, 0.0, 1.0]))
    return View(np.zeros((48, 64, 3), np.uint8), np.ones((48, 64), np.float32), cam)


def _obs(*views: View, tip=None) -> Observation:
    robot = None if tip is None else RobotState(np.eye(4), ee_points={"tip": np.asarray(tip, float)})
    return Observation(0.0, {v.camera.name: v for v in views}, robot=robot)


def test_a_view_with_the_wanted_name_is_used_whatever_its_geometry():
    obs = _obs(_view("top", (1.5, 0.0, 0.2)), _view("front", (0.6, 0.0, 1.4), target=(0.5, 0.01, 0.0)))
    assert question_view("top", obs) == "top" and question_view("front", obs) == "front"


def test_without_the_names_top_goes_to_the_steepest_view_and_front_to_the_most_level():
    level, mid, steep = (_view("a", (1.3, 0.3, 0.3)), _view("b", (0.5, -0.6, 0.7)),
                         _view("c", (0.55, 0.05, 1.2)))
    assert steepness(level.camera) < steepness(mid.camera) < steepness(steep.camera)
    for order in ((level, mid, steep), (steep, level, mid), (mid, steep, level)):
        obs = _obs(*order)
        assert question_view("top", obs) == "c"
        assert question_view("front", obs) == "a"


def test_a_camera_at_the_hand_is_not_asked_while_a_scene_view_exists():
    hand, scene = _view("cam0", (0.5, 0.0, 0.45)), _view("cam1", (1.2, 0.0, 0.6))
    assert steepness(hand.camera) > steepness(scene.camera)
    assert question_view("top", _obs(hand, scene, tip=(0.5, 0.0, 0.45 - HAND_RADIUS / 2))) == "cam1"
    assert question_view("top", _obs(hand, scene, tip=(0.2, 0.4, 0.3))) == "cam0"  # the hand is elsewhere
    assert question_view("top", _obs(hand, tip=(0.5, 0.0, 0.4))) == "cam0"  # the only view


def test_an_observation_without_views_is_a_clear_error():
    with pytest.raises(ObservationError, match="at least one view"):
        question_view("front", Observation(0.0, {}))
