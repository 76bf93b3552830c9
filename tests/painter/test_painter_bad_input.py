"""Bad input never crashes the painter: NaN / inf / zero depth patches, empty masks, an image / depth size
mismatch and a camera without intrinsics give missing (stale) elements or a specific error naming the value."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core import CameraModel, Constraint, ElementSpec, Observation, Phase, Subgoal, View
from code_as_monitor.core.errors import GeometryError, ShapeMismatchError
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter

POINT_TARGET = 0.008  # metres: the largest allowed point error (two views)


@pytest.fixture(scope="module")
def frame():
    """(observation, the red block's true centre) on one stack-in-order frame."""
    from code_as_monitor.bench.element_truth import part_truth
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=2, disturbed=False) as env:
        return env.world.observe(), part_truth(env.world, "red_block").centre


def _painter() -> Painter:
    return Painter(make_segmenter(SegmenterConfig.from_name("sim")))


def _with(obs: Observation, **views: View) -> Observation:
    return Observation(obs.t, {**obs.views, **views}, obs.robot)


def _patched(view: View, mask: np.ndarray, value: float) -> View:
    d = view.depth.copy()
    d[mask] = value
    return dataclasses.replace(view, depth=d)


def _centre_patch(mask: np.ndarray, half: int) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    r, c = int(np.median(rows)), int(np.median(cols))
    out = np.zeros_like(mask)
    out[max(0, r - half) : r + half, max(0, c - half) : c + half] = True
    return out & mask


@pytest.mark.parametrize("value", [np.nan, np.inf, 0.0, -1.0])
def test_depth_holes_on_the_part_leave_the_rest(frame, value: float) -> None:
    obs, truth = frame
    views = {n: _patched(v, _centre_patch(v.mask_of("red_block"), 3), value) for n, v in obs.views.items()}
    el = _painter().build_element(_with(obs, **views), 0, ElementSpec("red", "red_block"))
    assert el is not None and np.all(np.isfinite(el.points))
    assert np.linalg.norm(el.points[0] - truth) < POINT_TARGET


@pytest.mark.parametrize("value", [np.nan, np.inf, 0.0])
def test_a_part_without_any_valid_depth_is_missing(frame, value: float) -> None:
    obs, _ = frame
    views = {n: _patched(v, v.mask_of("red_block"), value) for n, v in obs.views.items()}
    specs = [ElementSpec("red", "red_block"), ElementSpec("green", "green_block")]
    res = _painter().paint(_with(obs, **views), Subgoal("s", [Constraint("c", "c", Phase.UPON, specs)]))
    assert [s.obj for s in res.missing] == ["red_block"]
    assert [e.owner[0] for e in res.elements] == ["green_block"]


def test_an_object_no_view_sees_is_missing(frame) -> None:
    obs, _ = frame
    views = {n: dataclasses.replace(v, seg=np.where(v.mask_of("blue_block"), -1, v.seg)) for n, v in obs.views.items()}
    assert _painter().build_element(_with(obs, **views), 0, ElementSpec("blue", "blue_block")) is None


def test_size_mismatch_is_named_and_a_mismatched_view_is_skipped(frame) -> None:
    obs, truth = frame
    front = obs.views["front"]
    with pytest.raises(ShapeMismatchError, match=r"'front'.*depth shape"):
        View(front.rgb, front.depth[:-1], front.camera, front.seg, front.seg_labels)
    broken = dataclasses.replace(front)
    broken.depth = front.depth[:, :-2]  # changed after construction: the painter must still not crash
    el = _painter().build_element(_with(obs, front=broken), 0, ElementSpec("red", "red_block"))
    assert el is not None and el.support.views == 1  # from the top view alone
    assert np.linalg.norm(el.points[0] - truth) < 0.02


def test_a_camera_without_intrinsics_is_named_and_its_view_skipped(frame) -> None:
    obs, _ = frame
    cam = obs.views["top"].camera
    with pytest.raises(GeometryError, match="intrinsics K must be 3x3"):
        CameraModel(cam.name, cam.width, cam.height, None, cam.T_world_cam)  # type: ignore[arg-type]
    with pytest.raises(GeometryError, match=r"not invertible \(fx=0.0"):
        CameraModel(cam.name, cam.width, cam.height, np.zeros((3, 3)), cam.T_world_cam)
    lost = dataclasses.replace(cam)
    object.__setattr__(lost, "K", None)  # a camera whose intrinsics went missing after construction
    only = Observation(obs.t, {"top": dataclasses.replace(obs.views["top"], camera=lost)}, obs.robot)
    specs = [ElementSpec("red", "red_block"), ElementSpec("tip", "robot", "tip")]
    res = _painter().paint(only, Subgoal("s", [Constraint("c", "c", Phase.UPON, specs)]))
    assert [s.obj for s in res.missing] == ["red_block"]  # stale, not a crash
    assert [e.owner[0] for e in res.elements] == ["robot"]  # forward kinematics needs no camera
    assert np.array_equal(res.images["top"], obs.views["top"].rgb)  # drawn as is
