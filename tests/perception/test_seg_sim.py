from __future__ import annotations

import numpy as np
import pytest
from perception_synth import Box, Scene, render, two_cameras

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import PerceptionError, UnknownChoiceError
from code_as_monitor.perception.segmenters.base import SegmenterConfig, make_segmenter


@pytest.fixture(scope="module")
def view():
    scene = Scene([Box("red_block", np.array([0.0, 0.0, 0.03]), np.array([0.06, 0.06, 0.06]))])
    return render(scene, two_cameras()[0])


def test_sim_segmenter_object_and_part(view):
    seg = make_segmenter(SegmenterConfig.from_name("sim"))
    whole = seg.segment(view, ElementSpec("red", "red_block", "", ElementKind.POINT))
    np.testing.assert_array_equal(whole.instance_mask, np.isin(view.seg, [10, 11]))
    np.testing.assert_array_equal(whole.part_mask, whole.instance_mask)
    assert whole.score == 1.0 and whole.kind is ElementKind.POINT
    top = seg.segment(view, ElementSpec("red top", "red_block", "top", ElementKind.SURFACE))
    np.testing.assert_array_equal(top.part_mask, view.seg == 11)
    np.testing.assert_array_equal(top.instance_mask, whole.instance_mask)
    assert top.kind is ElementKind.SURFACE and top.part_mask.sum() < top.instance_mask.sum()


def test_sim_segmenter_unknown_names(view):
    seg = make_segmenter(SegmenterConfig.from_name("sim"))
    with pytest.raises(PerceptionError, match="teapot"):
        seg.segment(view, ElementSpec("x", "teapot"))
    with pytest.raises(PerceptionError, match="spout"):
        seg.segment(view, ElementSpec("x", "red_block", "spout"))


def test_sim_segmenter_invisible_object_gives_empty_masks(view):
    labels = dict(view.seg_labels)
    labels[99] = ("green_block", "")  # known to the scene, not in the image
    v = type(view)(view.rgb, view.depth, view.camera, view.seg, labels)
    res = make_segmenter(SegmenterConfig.from_name("sim")).segment(v, ElementSpec("g", "green_block"))
    assert res.empty and res.score == 0.0 and not res.instance_mask.any()


def test_sim_segmenter_needs_seg(view):
    v = type(view)(view.rgb, view.depth, view.camera)
    with pytest.raises(PerceptionError, match="color or http"):
        make_segmenter(SegmenterConfig.from_name("sim")).segment(v, ElementSpec("r", "red_block"))


def test_unknown_segmenter_name():
    with pytest.raises(UnknownChoiceError, match="color"):
        SegmenterConfig.from_name("sam9")


def test_importing_perception_loads_no_backend_and_no_simulator():
    import subprocess
    import sys

    code = (
        "import sys, code_as_monitor.perception\n"
        "bad = [m for m in ('cv2', 'code_as_monitor.sim', 'code_as_monitor.perception.trackers.lk',"
        " 'code_as_monitor.perception.segmenters.http') if m in sys.modules]\n"
        "print(','.join(bad))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == ""


def test_sim_segmenter_robot_mask_is_the_robots_labels(view):
    seg = make_segmenter(SegmenterConfig.from_name("sim"))
    assert seg.robot_mask(view) is None  # no label is the robot's in this scene
    labels = dict(view.seg_labels)
    labels[10] = ("robot", "link5")  # say the block's side is an arm link
    from dataclasses import replace

    m = seg.robot_mask(replace(view, seg_labels=labels))
    np.testing.assert_array_equal(m, view.seg == 10)
    assert make_segmenter(SegmenterConfig.from_name("color")).robot_mask(view) is None


def test_sim_segmenter_many_equals_one_by_one_and_each_result_owns_its_masks(view):
    """``segment_many`` computes a union of ids once per call; every result still gets its own arrays, equal
    to what ``segment`` gives for its spec alone."""
    seg = make_segmenter(SegmenterConfig.from_name("sim"))
    specs = [ElementSpec("red", "red_block", ""), ElementSpec("red top", "red_block", "top", ElementKind.SURFACE),
             ElementSpec("red again", "red_block", ""), ElementSpec("red body", "red_block", "body")]
    many = seg.segment_many(view, specs)
    for spec, got in zip(specs, many):
        one = seg.segment(view, spec)
        np.testing.assert_array_equal(got.instance_mask, one.instance_mask)
        np.testing.assert_array_equal(got.part_mask, one.part_mask)
    arrays = [m for r in many for m in (r.instance_mask, r.part_mask)]
    assert not any(np.shares_memory(a, b) for i, a in enumerate(arrays) for b in arrays[i + 1:])
