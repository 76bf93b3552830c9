"""The visual prompt: every element's colour appears where its points project, and banners are drawn."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core import CameraModel, Element
from code_as_monitor.painter.draw import draw_banner, draw_elements


def _camera() -> CameraModel:
    return CameraModel.look_at("top", [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 320, 240, 60.0, up=[0, 1, 0])


def test_elements_are_drawn_in_their_colour_at_their_projection() -> None:
    cam = _camera()
    rgb = np.full((240, 320, 3), 90, np.uint8)
    els = [
        Element.point(0, "a", [0.1, 0.0, 0.0]),
        Element.line(1, "b", [-0.2, -0.1, 0.0], [-0.05, -0.1, 0.0]),
        Element.surface(2, "c", [[0.0, 0.1, 0.0], [0.15, 0.1, 0.0], [0.15, 0.2, 0.0], [0.0, 0.2, 0.0]]),
    ]
    out = draw_elements(rgb, cam, els)
    assert out.shape == rgb.shape and out.dtype == np.uint8
    assert np.array_equal(rgb, np.full((240, 320, 3), 90, np.uint8)), "input must not be modified"
    for el in els:
        uv, _ = cam.project(el.points)
        u, v = np.round(uv[0]).astype(int)
        patch = out[v - 2 : v + 3, u - 2 : u + 3].reshape(-1, 3).astype(int)
        dist = np.abs(patch - np.array(el.color)).sum(axis=1).min()
        assert dist < 40, f"element {el.id} colour not found at its projection"


def test_points_behind_the_camera_are_skipped() -> None:
    cam = _camera()
    rgb = np.zeros((240, 320, 3), np.uint8)
    out = draw_elements(rgb, cam, [Element.point(0, "behind", [0.0, 0.0, 2.0])])
    assert not out.any()


def test_banner_covers_the_top() -> None:
    out = draw_banner(np.zeros((240, 320, 3), np.uint8), "VIOLATION x", (200, 30, 30))
    assert (out[2, :, 0] == 200).mean() > 0.5
