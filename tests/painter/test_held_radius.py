"""The painter counts an object as held when the closed gripper's tip has one of its visible points within
``HELD_RADIUS``: the fingers cover the object around the grasp point, so the nearest visible point can lie 1.5 cm or
more from the tip (a book held upright: 1.6 cm)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from code_as_monitor.core import Observation, RobotState
from code_as_monitor.painter import Painter
from code_as_monitor.painter.painter import HELD_RADIUS, HELD_SIZE


class _Seg:
    def segment(self, view, spec):
        return SimpleNamespace(instance_mask=spec.obj)


class _Lifted:
    def __init__(self, clouds: dict[str, np.ndarray]) -> None:
        self.clouds = clouds

    def points(self, name: str) -> np.ndarray:
        return self.clouds.get(name, np.empty((0, 3)))


def _held(clouds: dict[str, np.ndarray], gripper: float = 1.0) -> list[str]:
    tip = np.array([0.5, 0.0, 0.3])
    robot = RobotState(np.eye(4), gripper=gripper, ee_kind="gripper", ee_points={"tip": tip})
    obs = Observation(0.0, {}, robot=robot, objects=[*clouds, "robot"])
    return list(Painter(_Seg())._held(obs, [(None, _Lifted(clouds), None)]))


def _slab(nearest: float, size: float = 0.12) -> np.ndarray:
    """Points of a flat object whose nearest visible point is ``nearest`` m beside the tip, extending ``size`` away."""
    s = np.linspace(nearest, nearest + size, 40)
    return np.stack([0.5 + s, np.zeros_like(s), np.full_like(s, 0.3)], axis=1)


def test_an_object_whose_nearest_visible_point_is_16_mm_from_the_tip_is_held() -> None:
    assert HELD_RADIUS >= 0.016
    assert _held({"book": _slab(0.016)}) == ["book"]


def test_an_object_beyond_the_radius_or_an_open_gripper_or_a_large_surface_is_not_held() -> None:
    assert _held({"book": _slab(HELD_RADIUS + 0.01)}) == []
    assert _held({"book": _slab(0.01)}, gripper=0.0) == []
    assert _held({"table": _slab(0.005, size=2 * HELD_SIZE)}) == [], "95 % of the table lies beyond HELD_SIZE"
