"""A line seen as a stub does not show its direction: weak.

Analytic scene (ray-cast depth, exact masks): a book standing on the table, 12 cm wide along x, 2.4 cm thick along
y, 20 cm tall, its spine (a 1 cm strip along one 20 cm edge, a part; the rest the cover, its sibling) facing the
front camera, seen from the benchmark's front and top cameras. In a tight shelf a wall stands 5 mm in front of it,
up to 2.8 cm below the book's top: the views see the spine's top 2.8 cm, and carving cannot take it further down (the
space behind the wall within 1 cm of its surface is taken to be the wall's). The fitted box is then about as long
as it is wide, and its longest axis, the line, lies wherever the outline and the depth noise make it longest (the
stow-book scene of ``benchmarks/element_accuracy.py``, seed 2 after the stow, 2 mm noise: 30 x 22 x 15 mm, 12.8
degrees off, called sound before). Without the wall the views see the spine's whole length: the line is vertical
and sound.
"""

from __future__ import annotations

import numpy as np
import pytest
from book_scene import CENTRE, book, off_vertical, paint_spine

from code_as_monitor.core.elements import ElementSupport
from code_as_monitor.geometry.elements import LINE_MIN_ASPECT
from code_as_monitor.geometry.raycast import Box

VISIBLE = 0.028  # metres of the spine above the wall


def _spine(wall: bool, yaw: float, noise_mm: float, seed: int = 0):
    """The spine's line element, the spine facing the front camera; ``wall``: a shelf wall hides all but its top."""
    R, prims = book(1.0, yaw)
    if wall:  # 2 mm thick, 5 mm in front of the spine's face, 30 cm wide, up to VISIBLE below the book's top
        h = 0.2 - VISIBLE
        prims.append(Box(CENTRE + R @ np.array([0.066, 0.0, h / 2.0 - 0.1]), np.array([0.001, 0.15, h / 2.0]), R))
    return paint_spine(prims, noise_mm, seed)


@pytest.mark.parametrize("yaw,noise_mm,seed", [(0.0, 0.0, 0), (0.0, 2.0, 0), (0.0, 2.0, 1), (8.0, 2.0, 2),
                                               (-8.0, 0.0, 0)])
def test_a_spine_seen_as_a_stub_above_a_wall_is_weak(yaw, noise_mm, seed):
    e = _spine(True, yaw, noise_mm, seed)
    sup = e.support
    assert sup is not None
    assert sup.extent[0] < LINE_MIN_ASPECT * sup.extent[1], sup  # the scene is what it says: a stub
    assert not sup.direction_seen and sup.weak(), sup


@pytest.mark.parametrize("yaw,noise_mm", [(0.0, 0.0), (0.0, 2.0), (8.0, 2.0), (-8.0, 0.0)])
def test_the_same_spine_seen_whole_is_vertical_and_sound(yaw, noise_mm):
    e = _spine(False, yaw, noise_mm)
    sup = e.support
    assert sup is not None
    assert off_vertical(e.points) < 2.0
    assert sup.direction_seen and not sup.weak(), sup


def test_direction_seen_survives_the_events_round_trip():
    sup = ElementSupport(30, 2, 0.001, 0.015, (0.03, 0.022, 0.015), direction_seen=False)
    back = ElementSupport.from_dict(sup.to_dict())
    assert back == sup and back.weak()
    seen = ElementSupport(300, 2, 0.001, 0.1, (0.2, 0.024, 0.01))
    assert "direction_seen" not in seen.to_dict() and ElementSupport.from_dict(seen.to_dict()).direction_seen
