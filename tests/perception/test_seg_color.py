from __future__ import annotations

import numpy as np
import pytest
from perception_synth import Box, Scene, render, two_cameras

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ConfigError, PerceptionError
from code_as_monitor.core.observation import View
from code_as_monitor.perception.segmenters.base import SegmenterConfig, make_segmenter


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max(1, (a | b).sum()))


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene([
        Box("red_block", np.array([0.0, 0.0, 0.025]), np.array([0.05, 0.05, 0.05]), (200, 30, 30), textured=False),
        Box("blue_block", np.array([0.08, 0.06, 0.02]), np.array([0.04, 0.04, 0.04]), (30, 50, 200), textured=False),
        # A red mark printed on the table: red, but flat.
        Box("mark", np.array([-0.08, 0.05, 0.0005]), np.array([0.05, 0.03, 0.001]), (200, 30, 30), textured=False),
    ])


@pytest.mark.parametrize("cam", two_cameras(), ids=lambda c: c.name)
def test_color_segmenter_finds_red_block_on_grey_table(scene, cam):
    view = render(scene, cam)
    seg = make_segmenter(SegmenterConfig.from_name("color"))
    res = seg.segment(view, ElementSpec("red", "red_block", "", ElementKind.POINT))
    truth = view.mask_of("red_block")
    assert _iou(res.instance_mask, truth) > 0.8
    assert not (res.instance_mask & view.mask_of("mark")).any()  # the flat red mark is table
    assert res.score > 0.5 and res.kind is ElementKind.POINT
    top = seg.segment(view, ElementSpec("red top", "red_block", "top", ElementKind.SURFACE))
    assert _iou(top.part_mask, view.mask_of("red_block", "top")) > 0.6
    assert not (top.part_mask & ~top.instance_mask).any()
    blue = seg.segment(view, ElementSpec("blue", "blue_block"))
    assert _iou(blue.instance_mask, view.mask_of("blue_block")) > 0.8


def test_color_segmenter_without_depth_uses_colour_only(scene):
    v = render(scene, two_cameras()[0])
    view = View(v.rgb, np.zeros_like(v.depth), v.camera)
    seg = make_segmenter(SegmenterConfig.from_name("color"))
    res = seg.segment(view, ElementSpec("red top", "red_block", "top"))
    assert _iou(res.instance_mask, v.mask_of("red_block")) > 0.8  # the flat mark is smaller: not the largest
    np.testing.assert_array_equal(res.part_mask, res.instance_mask)  # no depth: top = whole object


def test_color_segmenter_multi_instance_and_flat_objects(scene):
    view = render(scene, two_cameras()[0])
    seg = make_segmenter(SegmenterConfig.from_name("color", multi_instance=True, object_colors={"mark": "red"},
                                                   flat_objects=("mark",)))
    res = seg.segment(view, ElementSpec("mark", "mark"))
    assert _iou(res.instance_mask, view.mask_of("red_block") | view.mask_of("mark")) > 0.8


def test_color_segmenter_missing_and_unknown(scene):
    view = render(scene, two_cameras()[0])
    seg = make_segmenter(SegmenterConfig.from_name("color"))
    green = seg.segment(view, ElementSpec("green", "green_block"))
    assert green.empty and green.score == 0.0 and not green.instance_mask.any()
    with pytest.raises(PerceptionError, match="teapot"):
        seg.segment(view, ElementSpec("t", "teapot"))
    with pytest.raises(ConfigError, match="zone"):
        SegmenterConfig.from_name("color", object_colors={"zone": "ultraviolet"})
