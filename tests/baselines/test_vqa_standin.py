"""vqa-standin: single-image answers from colour blobs; kb-readable reasons; no privileged inputs."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from code_as_monitor.baselines import vqa_standin
from code_as_monitor.baselines.vqa import parse_yes_no
from code_as_monitor.baselines.vqa_standin import VQAStandin
from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.constraints import Constraint, ElementSpec, Phase
from code_as_monitor.core.errors import VLMOutputError
from code_as_monitor.core.observation import Observation, RobotState, View
from code_as_monitor.vlm.kb.shared.feedback import classify

RGB = {"red": (217, 38, 38), "green": (38, 191, 51), "blue": (38, 77, 230), "brick": (200, 70, 20),
       "yellow": (242, 217, 51)}
CAM = CameraModel.look_at("front", np.array([1.15, 0.0, 0.65]), np.array([0.5, 0.0, 0.0]), 320, 240, 45.0)


def _img() -> np.ndarray:
    return np.full((240, 320, 3), 25, dtype=np.uint8)


def _square(img, color, u, v, half=7) -> None:
    img[v - half:v + half, u - half:u + half] = RGB[color]


def _obs(img, tip=(0.5, 0.3, 0.02), name="front") -> Observation:
    view = View(img, np.full(img.shape[:2], np.nan, dtype=np.float32), CAM)
    T = np.eye(4)
    T[:3, 3] = tip
    return Observation(t=1.0, views={name: view},
                       robot=RobotState(ee_pose=T, ee_points={"tip": np.asarray(tip, dtype=float)}))


def _c(cid: str, *objs: str, phase=Phase.UPON, **thr) -> Constraint:
    parts = [ElementSpec(o, o, "", "point") for o in objs]
    return Constraint(cid, cid.replace("_", " "), phase, parts, thresholds=thr)


def test_on_top_in_the_image_plane():
    img = _img()
    _square(img, "red", 160, 150)
    _square(img, "green", 161, 136)
    s = VQAStandin()
    assert s.answer(_c("tower_green_block_on_red_block", "green_block", "red_block"), _obs(img)).yes
    apart = _img()
    _square(apart, "red", 160, 150)
    _square(apart, "green", 100, 150)
    ans = s.answer(_c("tower_green_block_on_red_block", "green_block", "red_block"), _obs(apart))
    assert not ans.yes and classify(ans.reason) == "collapse"


def test_a_hidden_lower_block_is_no_sign_of_a_collapse():
    """During a pick the arm can hide either block of the tower: the one image shows no collapse (the stand-in
    answered "no", and DoReMi, asking every second, re-planned 31 times on undisturbed towers); a block that
    cannot be seen resting on, or that cannot be seen, is still "no" for the upon checks."""
    s = VQAStandin()
    for shown in ("green", "red"):  # the other one hidden
        img = _img()
        _square(img, shown, 161, 136 if shown == "green" else 150)
        assert s.answer(_c("tower_green_block_on_red_block", "green_block", "red_block"), _obs(img)).yes
        assert not s.answer(_c("resting_green_block_on_red_block", "green_block", "red_block"), _obs(img)).yes


def test_centred_uses_horizontal_image_offset_only():
    s = VQAStandin()
    for du, ok in ((1, True), (7, False)):
        img = _img()
        _square(img, "red", 160, 150)
        _square(img, "green", 160 + du, 136)
        ans = s.answer(_c("centred_green_block_on_red_block", "green_block", "red_block", max_offset=0.015), _obs(img))
        assert ans.yes is ok
        if not ok:
            assert classify(ans.reason) == "offset"


def test_held_needs_the_block_under_the_tip_and_the_tip_lifted():
    s = VQAStandin()
    for z, ok in ((0.15, True), (0.03, False)):
        tip = np.array([0.5, 0.0, z])
        uv, _ = CAM.project(tip[None])
        img = _img()
        _square(img, "green", round(float(uv[0][0])), round(float(uv[0][1])) + 5)
        ans = s.answer(_c("held_green_block", "robot", "green_block", min_z=0.05), _obs(img, tip=tip))
        assert ans.yes is ok
    assert classify(ans.reason) == "dropped"


def test_counting_blocks_in_the_zone_from_the_top_view():
    img = _img()
    img[60:140, 100:180] = RGB["yellow"]
    for k in range(5):
        img[70 + 12 * k:74 + 12 * k, 110:114] = RGB["brick"]
    for k in range(3):
        img[200:204, 20 + 10 * k:24 + 10 * k] = RGB["brick"]
    view = View(img, np.zeros((240, 320), np.float32), CAM)
    assert VQAStandin().count_in_zone(view) == 5
    zone = [ElementSpec("zone", "zone", "surface", "surface")]
    c = Constraint("reached_half_in_zone", "at least 4", Phase.UPON, zone, thresholds={"target": 4, "upper": 24})
    assert VQAStandin().view_for(c) == "top"
    assert VQAStandin().answer(c, _obs(img, name="top")).yes


def test_never_reads_depth_segmentation_or_object_poses():
    src = inspect.getsource(vqa_standin)
    code = src.split('"""', 2)[2]  # past the module docstring, which names what it must not read
    for banned in (".depth", ".seg", "object_poses", "seg_labels"):
        assert banned not in code


def test_parse_yes_no():
    assert parse_yes_no("Yes. The block is held.").yes
    a = parse_yes_no("no - the tower fell")
    assert not a.yes and a.reason == "the tower fell"
    with pytest.raises(VLMOutputError):
        parse_yes_no("maybe")
