"""CS off: elements from ORB keypoints in the object's image region, lifted and k-means clustered (not DINOv2)."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core import ElementKind, ElementSpec
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.geometry.helpers import normal
from code_as_monitor.painter import Painter
from code_as_monitor.painter.keypoint_elements import ccw_about_normal, element_from_keypoints, orb_keypoints


def _checkerboard(h: int = 120, w: int = 160, cell: int = 8) -> np.ndarray:
    yy, xx = np.mgrid[:h, :w]
    img = (((yy // cell) + (xx // cell)) % 2 * 200 + 30).astype(np.uint8)
    return np.repeat(img[..., None], 3, axis=2)


def test_orb_keypoints_lie_inside_the_mask_only() -> None:
    rgb = _checkerboard()
    mask = np.zeros(rgb.shape[:2], dtype=bool)
    mask[30:90, 40:120] = True
    uv = orb_keypoints(rgb, mask)
    assert len(uv) >= 8
    assert np.all(mask[uv[:, 1], uv[:, 0]])
    assert len(orb_keypoints(rgb, np.zeros_like(mask))) == 0


def test_point_line_and_surface_from_keypoint_clusters() -> None:
    rng = np.random.default_rng(0)
    # two blobs 20 cm apart vertically (a standing object's two ends), 4 blobs on a table-level square
    ends = np.vstack([rng.normal([0.5, 0.0, 0.05], 0.005, (30, 3)), rng.normal([0.5, 0.0, 0.25], 0.005, (30, 3))])
    line = element_from_keypoints(1, ElementSpec("spine", "book", "spine", "line"), ends)
    assert line.kind is ElementKind.LINE and line.owner == ("book", "spine")
    assert line.points[0][2] > line.points[1][2], "the higher end first"
    assert np.allclose(line.points[:, 2], [0.25, 0.05], atol=0.01)
    point = element_from_keypoints(0, ElementSpec("cover", "book", "cover", "point"), ends)
    assert np.allclose(point.points[0], ends.mean(axis=0))
    corners = np.array([[0.4, -0.1, 0.08], [0.6, -0.1, 0.08], [0.6, 0.1, 0.08], [0.4, 0.1, 0.08]])
    blobs = np.vstack([rng.normal(c, 0.004, (20, 3)) for c in corners[[2, 0, 3, 1]]])
    surf = element_from_keypoints(2, ElementSpec("slot", "shelf", "slot", "surface"), blobs)
    assert surf.kind is ElementKind.SURFACE and normal(surf.points)[2] > 0.99
    assert len(surf.cloud) == len(blobs)


def test_too_few_keypoints_give_no_element() -> None:
    one = np.array([[0.5, 0.0, 0.1]] * 5)
    assert element_from_keypoints(0, ElementSpec("spine", "book", "spine", "line"), one) is None
    assert element_from_keypoints(0, ElementSpec("c", "book", "", "point"), np.zeros((0, 3))) is None


def test_corners_are_ordered_counter_clockwise_seen_from_above() -> None:
    sq = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    o = ccw_about_normal(sq)
    c = o - o.mean(axis=0)
    turns = [np.cross(c[i], c[(i + 1) % 4])[2] for i in range(4)]
    assert all(t > 0 for t in turns)


def test_the_painter_refuses_an_unknown_source() -> None:
    with pytest.raises(ConfigError, match=r"element_source.*'dinov2'"):
        Painter(object(), element_source="dinov2")
    with pytest.raises(ConfigError, match="connect_points"):
        Painter(object(), connect_points=1)  # type: ignore[arg-type]
