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


def _label_boxes(out: np.ndarray, rgb: np.ndarray) -> np.ndarray:
    """Pixels of the dark label backings (20, 20, 20) drawn over a mid-grey image."""
    return (np.abs(out.astype(int) - 20).sum(axis=2) < 6) & (np.abs(rgb.astype(int) - 20).sum(axis=2) > 6)


def test_labels_of_nearby_elements_do_not_overlap() -> None:
    from code_as_monitor.painter.draw import _label_size, place_labels

    sizes = [_label_size(str(i), 1.0) for i in range(6)]
    anchors = [(160 + 3 * i, 120 + 2 * i) for i in range(6)]  # six elements within a few pixels
    origins = place_labels(anchors, sizes, (240, 320, 3), 5)
    boxes = [(x - 2, y - h - 3, x + w + 2, y + b + 1) for (x, y), (w, h, b) in zip(origins, sizes)]
    for i in range(len(boxes)):
        for j in range(i):
            a, c = boxes[i], boxes[j]
            assert min(a[2], c[2]) <= max(a[0], c[0]) or min(a[3], c[3]) <= max(a[1], c[1]), (i, j)
    # a lone label keeps the usual spot (up-right of its anchor)
    (x, y), = place_labels([(100, 100)], sizes[:1], (240, 320, 3), 5)
    assert x > 100 and y < 100


def test_hidden_elements_get_faded_labels() -> None:
    cam = _camera()
    rgb = np.full((240, 320, 3), 90, np.uint8)
    el = Element.point(7, "a", [0.1, 0.0, 0.0])
    shown = draw_elements(rgb, cam, [el])
    hidden = draw_elements(rgb, cam, [el], stale={7: np.array([True])})
    assert _label_boxes(shown, rgb).sum() > 30  # a solid dark backing
    assert _label_boxes(hidden, rgb).sum() == 0  # blended into the picture: no solid backing
    partly = draw_elements(rgb, cam, [Element.line(3, "b", [0.1, 0.0, 0.0], [0.1, 0.1, 0.0])],
                           stale={3: np.array([True, False])})
    assert _label_boxes(partly, rgb).sum() > 30  # one point still seen: not hidden
