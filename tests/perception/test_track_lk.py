from __future__ import annotations

import numpy as np
import pytest
from perception_synth import Box, Scene, camera, observe, two_cameras

from code_as_monitor.core.elements import Element, ElementSupport
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.perception.trackers.base import LKTrackerConfig, TrackerConfig, make_tracker
from code_as_monitor.perception.trackers.lk_state import chroma_at, chroma_kept, views_agree

TOP = np.array([[-0.015, -0.015, 0.06], [0.015, -0.015, 0.06], [0.015, 0.015, 0.06], [-0.015, 0.015, 0.06]])


def _block(center=(0.0, 0.0, 0.03)) -> Box:
    return Box("red_block", np.array(center, float), np.array([0.06, 0.06, 0.06]))


def _elements() -> list[Element]:
    return [
        Element.surface(0, "red top", TOP, owner=("red_block", "top")),
        Element.point(1, "red centre", np.array([0.0, 0.0, 0.06]), owner=("red_block", "")),
        Element.point(2, "tip", np.array([0.0, 0.0, 0.3]), owner=("robot", "tip")),
    ]


@pytest.mark.parametrize("rigid", [True, False])
def test_lk_follows_textured_block_in_3d(rigid):
    cams = two_cameras()
    box = _block()
    scene = Scene([box])
    els = _elements()
    tr = make_tracker(TrackerConfig.from_name("lk", rigid=rigid))
    tr.reset(observe(scene, cams, 0.0, tip=np.array([0.0, 0.0, 0.3])), els)
    v = np.array([0.005, 0.002, 0.0])  # 5.4 mm per frame
    for f in range(1, 21):
        box.center = box.center + v
        tip = np.array([0.0, 0.01 * f, 0.3])
        res = tr.step(observe(scene, cams, 0.1 * f, tip=tip))
        for e in els[:2]:
            err = np.linalg.norm(res.points[e.id] - (e.points + f * v), axis=1).max()
            assert err < 0.01, (f, e.name, err)
            assert not res.stale[e.id].any() and res.visible_views[e.id] == 2
            # the anchors behind its fused points, over both views: at most 6 per point and view
            assert 0 < res.support[e.id] <= 2 * 6 * len(e.points), (f, e.name, res.support[e.id])
        np.testing.assert_allclose(res.points[2], tip[None])  # forward kinematics, not images
        assert res.support[2] == float("inf")
    assert res.t == pytest.approx(2.0)


def _fov(cam) -> float:
    return float(np.degrees(2 * np.arctan(0.5 * cam.height / cam.K[1, 1])))


def _front_axis(cam) -> np.ndarray:
    d = cam.T_world_cam[:3, 0].copy()  # camera x axis (image right) in the world
    d[2] = 0.0
    return d / np.linalg.norm(d)


def test_lk_point_leaving_one_view_is_reacquired_from_the_other():
    front, side = two_cameras()
    d = -_front_axis(front)  # image left in the front view
    # Turn the front camera so that the block's top centre sits ~30 px from its left border.
    centre = np.array([0.0, 0.0, 0.06])
    for a in np.linspace(0.0, 0.3, 301):
        cam = camera("front", front.position, np.array([0.0, 0.0, 0.02]) - a * d, fov=_fov(front))
        if cam.project(centre)[0][0, 0] < 30:
            break
    cams = [cam, side]
    box = _block()
    scene = Scene([box])
    els = _elements()[:2]
    # One anchor per point: with more, the block's pixels beside the point keep it observed in the front
    # view (tested below); this test is about re-seeding a view from another one.
    tr = make_tracker(TrackerConfig.from_name("lk", anchors=1))
    tr.reset(observe(scene, cams, 0.0), els)
    step = 0.006 * d  # leaves the front image within a few frames, then comes back
    path = [step] * 8 + [-step] * 8
    seen = []
    pos = np.zeros(3)
    for f, dp in enumerate(path, start=1):
        pos = pos + dp
        box.center = np.array([0.0, 0.0, 0.03]) + pos
        res = tr.step(observe(scene, cams, 0.1 * f))
        seen.append(res.visible_views[1])
        assert not res.stale[1].any(), f  # the side view keeps it
        assert np.linalg.norm(res.points[1] - (els[1].points + pos)) < 0.01
    assert min(seen) == 1, seen  # it left the front image ...
    assert seen[-1] == 2, seen  # ... and was re-seeded there from the side view


def test_lk_occluded_everywhere_is_stale_keeps_last_value_and_calls_reacquire():
    cams = two_cameras()
    box = _block()
    board = Box("board", np.array([0.0, 0.0, 0.2]), np.array([0.4, 0.4, 0.01]), color=(90, 90, 200), texture_seed=5)
    scene = Scene([box])
    els = _elements()[:2]
    calls: list[tuple[float, int]] = []
    found: set[int] = set()  # ids the "painter" can find again

    def reacquire(obs, el):  # stands in for the painter: the element where the block now is
        calls.append((obs.t, el.id))
        shift = box.center - np.array([0.0, 0.0, 0.03])
        if el.id not in found:
            return None
        if el.id == 1:
            return Element.point(1, "red centre", np.array([0.0, 0.0, 0.06]) + shift, owner=("red_block", ""),
                                 support=ElementSupport(50, 2, 0.001, robot_hidden=0.2))
        return Element.surface(0, "red top", TOP[:3] + shift, owner=("red_block", "top"))  # 3 points, not 4

    tr = make_tracker(TrackerConfig.from_name("lk", reacquire_after=3))
    tr.set_reacquire(reacquire)
    tr.reset(observe(scene, cams, 0.0), els)
    v = np.array([0.004, 0.0, 0.0])
    res = None
    for f in range(1, 4):
        box.center = box.center + v
        res = tr.step(observe(scene, cams, 0.1 * f))
        assert not res.stale[1].any()
    last = {i: p.copy() for i, p in res.points.items()}
    scene.boxes.append(board)  # covers the block in both views
    for f in range(4, 9):
        box.center = box.center + v  # still moving, unseen
        res = tr.step(observe(scene, cams, 0.1 * f))
        for i in (0, 1):
            assert res.stale[i].all()
            np.testing.assert_array_equal(res.points[i], last[i])  # never replaced by garbage
            assert res.visible_views[i] == 0 and res.support[i] == 0.0  # nothing supports a held position
    assert calls and {i for _, i in calls} == {0, 1}  # hook ran after reacquire_after stale frames
    # The board goes away; the painter (hook) finds the block again where it now is.
    scene.boxes.remove(board)
    moved = box.center - np.array([0.0, 0.0, 0.03])
    found.add(1)
    n_before, reacquired = len(calls), 0
    for f in range(9, 14):
        n = len(calls)
        res = tr.step(observe(scene, cams, 0.1 * f))
        if 1 in {i for _, i in calls[n:]}:  # re-acquired now: its position is a paint, supported by its points
            reacquired += 1
            assert not res.stale[1].any() and res.support[1] == pytest.approx(40.0)
    assert len(calls) > n_before and reacquired == 1
    assert not res.stale[1].any()
    np.testing.assert_allclose(res.points[1], np.array([[0.0, 0.0, 0.06]]) + moved, atol=0.005)
    assert res.stale[0].all()  # the hook found nothing for it: still stale, still at its last value
    np.testing.assert_array_equal(res.points[0], last[0])
    # Now the painter finds the top again, with 3 points instead of 4; the block keeps moving.
    found.add(0)
    for f in range(14, 24):
        box.center = box.center + v
        res = tr.step(observe(scene, cams, 0.1 * f))
    shift = box.center - np.array([0.0, 0.0, 0.03])
    assert res.points[0].shape == (3, 3) and not res.stale[0].any()
    np.testing.assert_allclose(res.points[0], TOP[:3] + shift, atol=0.005)
    np.testing.assert_allclose(res.points[1], np.array([[0.0, 0.0, 0.06]]) + shift, atol=0.005)


def test_lk_config_validation():
    with pytest.raises(ConfigError, match="window"):
        LKTrackerConfig(window=20)
    with pytest.raises(ConfigError, match="fusion"):
        LKTrackerConfig(fusion="max")
    with pytest.raises(ConfigError, match="unknown option"):
        TrackerConfig.from_name("lk", windw=21)


@pytest.mark.parametrize("anchors", [1, 6])
def test_lk_point_under_a_cover_is_followed_through_its_anchors(anchors):
    """A cap over the block's top centre (a suction cup) hides the point's own pixel in both views.

    With one anchor the point is lost (stale, kept in place); with several, the block's surface beside
    the cap keeps it observed while block and cap move together.
    """
    cams = two_cameras()
    box = _block()
    cap = Box("cup", np.array([0.0, 0.0, 0.2]), np.array([0.026, 0.026, 0.03]), color=(60, 60, 60), texture_seed=9)
    scene = Scene([box, cap])
    els = _elements()[1:2]  # the top-centre point
    tr = make_tracker(TrackerConfig.from_name("lk", anchors=anchors))
    tr.reset(observe(scene, cams, 0.0), els)
    for f, z in enumerate(np.linspace(0.17, 0.075, 8), start=1):  # the cup comes down onto the point
        cap.center = np.array([0.0, 0.0, z])
        res = tr.step(observe(scene, cams, 0.1 * f))
    v = np.array([0.0, 0.0, 0.006])  # lifted together, 6 mm per frame
    for f in range(2, 12):
        box.center = box.center + v
        cap.center = cap.center + v
        res = tr.step(observe(scene, cams, 1.0 + 0.1 * f))
    truth = els[0].points + 10 * v
    if anchors == 1:
        assert res.stale[1].all()
        assert np.linalg.norm(res.points[1] - truth) > 0.05  # kept at its last (old) value
    else:
        assert not res.stale[1].any()
        assert np.linalg.norm(res.points[1] - truth) < 0.01


@pytest.mark.parametrize("prior", [0.0, 0.08])
def test_lk_end_effector_motion_prior_follows_a_fast_held_block(prior):
    """A block carried at 4 cm per frame with the tip: the kinematic guess lets LK keep it."""
    cams = two_cameras()
    box = _block()
    scene = Scene([box])
    els = _elements()[1:2]
    tip0 = np.array([0.0, 0.0, 0.07])
    tr = make_tracker(TrackerConfig.from_name("lk", ee_prior_radius=prior, anchors=1))
    tr.reset(observe(scene, cams, 0.0, tip=tip0), els)
    v = np.array([0.04, 0.0, 0.0])
    errs = []
    for f in range(1, 6):
        box.center = box.center + v
        res = tr.step(observe(scene, cams, 0.1 * f, tip=tip0 + f * v))
        errs.append(np.inf if res.stale[1].any() else np.linalg.norm(res.points[1] - (els[0].points + f * v)))
    if prior:
        assert max(errs) < 0.01, errs
    else:
        assert max(errs) > 0.01, errs  # without the prior the track is lost or left behind


def test_chromaticity_ignores_shading_and_skips_dark_pixels():
    rgb = np.zeros((10, 10, 3), np.uint8)
    rgb[:, :5] = (40, 160, 40)  # a green face ...
    rgb[:, 5:] = (20, 80, 20)  # ... and the same green in shade
    rgb[0:3, 0:3] = (5, 20, 5)  # too dark for a colour
    got = chroma_at(rgb, np.array([[2.0, 6.0], [7.0, 6.0], [1.0, 1.0], [np.nan, 3.0]]), min_sum=60.0)
    np.testing.assert_allclose(got[0], [40 / 240, 160 / 240])
    np.testing.assert_allclose(got[1], got[0])  # shading does not change chromaticity
    assert np.isnan(got[2:]).all()  # dark, or not a pixel: unknown
    red = chroma_at(np.full((3, 3, 3), (160, 40, 40), np.uint8), np.array([[1.0, 1.0]]), 60.0)
    seeded = np.vstack([got[0], got[0], got[0]])
    now = np.vstack([got[1], red[0], [np.nan, np.nan]])
    assert chroma_kept(seeded, now, 0.2).tolist() == [True, False, True]  # unknown is kept
    assert chroma_kept(seeded, now, 0.0).all()  # 0: the test is off


def test_views_agree_flags_points_two_views_place_apart():
    per_view = np.array([
        [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.0, 0.0], [np.nan] * 3],
        [[0.004, 0.0, 0.0], [0.13, 0.0, 0.0], [np.nan] * 3, [np.nan] * 3],
    ])
    observed = np.isfinite(per_view[:, :, 0])
    assert views_agree(per_view, observed, 0.01).tolist() == [True, False, True, True]
    assert views_agree(per_view, observed, 0.0).all()  # 0: the test is off
    assert views_agree(per_view[:1], observed[:1], 0.01).all()  # one view: nothing to compare


@pytest.mark.parametrize("max_change", [0.0, 0.2])
def test_lk_anchor_whose_colour_changes_is_lost(max_change):
    """The block stays where it is but its surface turns from red to green (what an anchor that slid onto the
    green block above a red one sees): with the colour test the point goes stale, without it it stays fresh."""
    cams = two_cameras()
    box = _block()
    scene = Scene([box])
    els = _elements()[1:2]
    tr = make_tracker(TrackerConfig.from_name("lk", max_chroma_change=max_change, max_view_disagreement=0.0))
    tr.reset(observe(scene, cams, 0.0), els)
    res = tr.step(observe(scene, cams, 0.1))
    assert not res.stale[1].any()
    box.color = (40, 120, 40)  # the grey level of the red (200, 40, 40): LK still matches it
    res = tr.step(observe(scene, cams, 0.2))
    assert res.stale[1].all() == (max_change > 0)
    np.testing.assert_allclose(res.points[1], els[0].points, atol=0.005)


def test_lk_new_options_validated():
    with pytest.raises(ConfigError, match="max_chroma_change"):
        LKTrackerConfig(max_chroma_change=-0.1)
    with pytest.raises(ConfigError, match="max_view_disagreement"):
        LKTrackerConfig(max_view_disagreement=float("nan"))
