"""Back-projection: exact on analytic depth, invalid readings skipped, bad input named."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import GeometryError, NoValidDepthError, ShapeMismatchError
from code_as_monitor.geometry import backproject_mask, backproject_pixels, sample_depth, transform_points
from code_as_monitor.geometry.synthetic import SyntheticScene


def _cam(width: int = 64, height: int = 48, T: np.ndarray | None = None) -> CameraModel:
    K = np.array([[50.0, 0.0, 31.5], [0.0, 55.0, 23.5], [0.0, 0.0, 1.0]])
    return CameraModel("c", width, height, K, np.eye(4) if T is None else T)


def test_fronto_parallel_plane_in_camera_frame() -> None:
    cam = _cam()
    depth = np.full((48, 64), 2.0, dtype=np.float32)
    mask = np.zeros((48, 64), dtype=bool)
    mask[10, 20] = mask[30, 40] = True
    P = backproject_mask(mask, depth, cam)
    # row-major order: (v=10, u=20) first; x = (u - cx) / fx * z, y = (v - cy) / fy * z (y down)
    np.testing.assert_allclose(P[0], [(20 - 31.5) / 50 * 2, (10 - 23.5) / 55 * 2, 2.0])
    np.testing.assert_allclose(P[1], [(40 - 31.5) / 50 * 2, (30 - 23.5) / 55 * 2, 2.0])


def test_world_frame_uses_T_world_cam() -> None:
    T = np.eye(4)
    T[:3, :3] = [[1, 0, 0], [0, -1, 0], [0, 0, -1]]  # looking straight down from z = 1
    T[:3, 3] = [0.5, -0.2, 1.0]
    cam = _cam(T=T)
    depth = np.full((48, 64), 0.8, dtype=np.float32)
    mask = np.ones((48, 64), dtype=bool)
    P = backproject_mask(mask, depth, cam)
    np.testing.assert_allclose(P[:, 2], 0.2, atol=1e-12)  # a table at z = 0.2
    P_cam = backproject_mask(mask, depth, _cam())
    np.testing.assert_allclose(P, transform_points(T, P_cam), atol=1e-12)
    # and reprojection lands on the pixel centres
    uv, z = cam.project(P)
    v, u = np.nonzero(mask)
    np.testing.assert_allclose(uv, np.c_[u, v], atol=1e-9)
    np.testing.assert_allclose(z, 0.8, atol=1e-12)


def test_invalid_depth_is_skipped() -> None:
    cam = _cam()
    depth = np.full((48, 64), 1.0, dtype=np.float32)
    depth[0, :6] = [0.0, np.nan, np.inf, -1.0, 7.0, 4.9]
    mask = np.zeros((48, 64), dtype=bool)
    mask[0, :6] = True
    P = backproject_mask(mask, depth, cam, max_depth=5.0)
    assert P.shape == (1, 3)
    assert P[0, 2] == pytest.approx(4.9, rel=1e-6)
    assert backproject_mask(mask, depth, cam, max_depth=10.0).shape == (2, 3)


def test_mask_accepts_integer_dtype_and_float64_depth() -> None:
    cam = _cam()
    mask = np.zeros((48, 64), dtype=np.uint8)
    mask[5:7, 5:8] = 1
    assert backproject_mask(mask, np.ones((48, 64)), cam).shape == (6, 3)


def test_bad_input_raises_named_errors() -> None:
    cam = _cam()
    depth = np.ones((48, 64), dtype=np.float32)
    with pytest.raises(ShapeMismatchError, match=r"mask shape \(48, 63\) does not match depth shape"):
        backproject_mask(np.ones((48, 63), bool), depth, cam)
    with pytest.raises(ShapeMismatchError, match="does not match the camera"):
        backproject_mask(np.ones((10, 10), bool), np.ones((10, 10)), cam)
    with pytest.raises(ShapeMismatchError, match=r"depth must be \(H, W\)"):
        backproject_mask(np.ones((48, 64), bool), np.ones((48, 64, 1)), cam)
    with pytest.raises(NoValidDepthError, match=r"'c'.*no valid depth"):
        backproject_mask(np.ones((48, 64), bool), np.zeros((48, 64)), cam)
    with pytest.raises(NoValidDepthError):
        backproject_mask(np.zeros((48, 64), bool), depth, cam)
    assert backproject_mask(np.zeros((48, 64), bool), depth, cam, allow_empty=True).shape == (0, 3)
    with pytest.raises(GeometryError, match="max_depth"):
        backproject_mask(np.ones((48, 64), bool), depth, cam, max_depth=0.0)
    with pytest.raises(ShapeMismatchError, match=r"uv must be \(N, 2\)"):
        backproject_pixels(np.zeros((3, 3)), depth, cam)


def test_backproject_pixels_matches_mask_path_on_smooth_depth() -> None:
    cam = _cam()
    v, u = np.mgrid[0:48, 0:64]
    depth = (1.0 + 0.01 * u + 0.005 * v).astype(np.float64)  # a slanted plane, linear in the image
    uv = np.array([[10.0, 10.0], [33.0, 20.0], [50.0, 40.0]])
    pts, valid = backproject_pixels(uv, depth, cam)
    assert valid.all()
    mask = np.zeros((48, 64), bool)
    mask[10, 10] = mask[20, 33] = mask[40, 50] = True
    np.testing.assert_allclose(pts, backproject_mask(mask, depth, cam), atol=1e-9)


def test_backproject_pixels_is_robust_and_flags_invalid() -> None:
    cam = _cam()
    depth = np.full((48, 64), 1.5, dtype=np.float32)
    depth[20, 30] = np.nan  # a missing reading under the tracked pixel
    depth[21, 31] = 0.3  # and one wrong one next to it
    depth[0:3, 0:3] = 0.0  # a hole bigger than the 3x3 window around (1, 1)
    uv = np.array([[30.2, 19.8], [1.0, 1.0], [-5.0, 3.0], [70.0, 3.0], [np.nan, 2.0], [63.4, 47.4]])
    pts, valid = backproject_pixels(uv, depth, cam)
    np.testing.assert_array_equal(valid, [True, False, False, False, False, True])
    assert pts[0, 2] == pytest.approx(1.5)  # camera frame == world frame here
    assert pts[0, 0] == pytest.approx((30.2 - 31.5) / 50 * 1.5)  # lifted at the sub-pixel position
    assert np.isnan(pts[~valid]).all()
    pts, valid = backproject_pixels(np.zeros((0, 2)), depth, cam)
    assert pts.shape == (0, 3) and valid.shape == (0,)


def test_sample_depth_median_at_an_edge() -> None:
    depth = np.ones((10, 10))
    depth[:, 5:] = 2.0  # a depth edge between columns 4 and 5
    z = sample_depth(np.array([[4.0, 5.0], [5.0, 5.0], [3.0, 5.0], [6.0, 5.0]]), depth)
    np.testing.assert_allclose(z, [1.0, 2.0, 1.0, 2.0])  # 6 of 9 neighbours win, never a blend
    depth[4:7, 4:6] = np.nan  # 6 missing -> median of the 3 valid ones
    assert sample_depth(np.array([[5.0, 5.0]]), depth)[0] == pytest.approx(2.0)


def test_scene_back_projection_lies_on_the_box(scene: SyntheticScene) -> None:
    """Noise-free rendered depth back-projects onto the analytic box surface and reprojects exactly."""
    box = scene.object("box").shape
    for cam in scene.cameras:
        _, depth, seg = scene.render(cam)
        mask = np.isin(seg, [i for i, (o, _) in scene.labels.items() if o == "box"])
        P = backproject_mask(mask, depth, cam)
        local = np.abs((P - box.center) @ box.R)  # |coordinates| in the box frame
        # on the surface: inside the box (float32 depth: ~1e-7 relative) and on at least one face
        assert (local <= box.half + 1e-5).all()
        assert (np.abs(local - box.half).min(axis=1) < 1e-5).all()
        uv, _ = cam.project(P)
        v, u = np.nonzero(mask)
        np.testing.assert_allclose(uv, np.c_[u, v], atol=1e-4)


def test_lift_depth_matches_per_pixel_lifting_and_zeroes_invalid_pixels() -> None:
    """The whole-image lift (cached rays per camera) gives the per-pixel result for every valid pixel and
    0 elsewhere; two poses of the same intrinsics do not share rays."""
    from code_as_monitor.geometry.backproject import lift_depth

    rng = np.random.default_rng(3)
    c, s = np.cos(0.7), np.sin(0.7)
    T = np.eye(4)
    T[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    T[:3, 3] = [0.3, -0.1, 1.2]
    depth = rng.uniform(0.2, 3.0, (48, 64)).astype(np.float32)
    depth[rng.random((48, 64)) < 0.2] = np.nan
    depth[0, :5] = [0.0, -1.0, np.inf, 9.0, 1.0]
    for cam in (_cam(T=T), _cam()):
        pts, valid = lift_depth(depth, cam)
        assert pts.shape == (48, 64, 3) and valid.dtype == bool
        assert not valid[0, :4].any() and valid[0, 4]
        np.testing.assert_allclose(pts[valid], backproject_mask(valid, depth, cam), rtol=0, atol=1e-12)
        assert not pts[~valid].any()


def test_lifted_view_lifts_only_the_asked_pixels_as_lift_depth_does() -> None:
    """``LiftedView.points(mask)`` equals the whole-image lift at the mask's valid pixels, in the same order;
    invalid readings inside the mask are skipped."""
    from code_as_monitor.geometry.backproject import LiftedView, lift_depth

    rng = np.random.default_rng(5)
    depth = rng.uniform(0.2, 3.0, (48, 64)).astype(np.float32)
    depth[rng.random((48, 64)) < 0.2] = np.nan
    cam = _cam()
    mask = np.zeros((48, 64), bool)
    mask[10:20, 5:30] = True
    pts, valid = lift_depth(depth, cam)
    lifted = LiftedView(depth, cam)
    assert (lifted.valid == valid).all()
    got = lifted.points(mask)
    assert got.shape == (int((mask & valid).sum()), 3) and 0 < len(got) < mask.sum()
    np.testing.assert_array_equal(got, pts[mask & valid])
    assert lifted.points(np.zeros_like(mask)).shape == (0, 3)


def test_lifted_view_lifts_a_window_of_the_mask_as_the_whole_mask() -> None:
    """``LiftedView.points(window, corner)``: the same points, in the same order, as the whole-image mask that
    holds that window at ``corner`` (row, column)."""
    from code_as_monitor.geometry.backproject import LiftedView

    rng = np.random.default_rng(6)
    depth = rng.uniform(0.2, 3.0, (48, 64)).astype(np.float32)
    depth[rng.random((48, 64)) < 0.2] = np.nan
    lifted = LiftedView(depth, _cam())
    mask = np.zeros((48, 64), bool)
    mask[12:19, 30:41] = rng.random((7, 11)) < 0.6
    whole = lifted.points(mask)
    assert len(whole) > 0
    np.testing.assert_array_equal(lifted.points(mask[12:19, 30:41], (12, 30)), whole)
    np.testing.assert_array_equal(lifted.points(mask[10:20, 28:44], (10, 28)), whole)
    assert not np.array_equal(lifted.points(mask[12:19, 30:41]), whole)  # the corner matters


def _scattered_masks(rng: np.random.Generator, shape: tuple[int, int]) -> list[np.ndarray]:
    """Empty, full, a pixel in each corner, and blobs anywhere (thinned at random)."""
    H, W = shape
    masks = [np.zeros(shape, bool), np.ones(shape, bool)]
    for r, c in ((0, 0), (H - 1, W - 1), (0, W - 1), (H - 1, 0)):
        m = np.zeros(shape, bool)
        m[r, c] = True
        masks.append(m)
    for _ in range(30):
        m = np.zeros(shape, bool)
        for _ in range(rng.integers(1, 4)):  # one to three blobs: the window spans them all
            r0, c0 = rng.integers(0, H - 8), rng.integers(0, W - 8)
            m[r0:r0 + rng.integers(1, 9), c0:c0 + rng.integers(1, 9)] = True
        m &= rng.random(shape) < 0.7
        masks.append(m)
    return masks


def test_mask_pixels_are_numpy_nonzero_in_the_same_order() -> None:
    from code_as_monitor.geometry.backproject import mask_pixels

    rng = np.random.default_rng(8)
    for m in _scattered_masks(rng, (48, 64)):
        rows, cols = mask_pixels(m)
        want_r, want_c = np.nonzero(m)
        assert rows.dtype == np.int64 and cols.dtype == np.int64
        np.testing.assert_array_equal(rows, want_r)
        np.testing.assert_array_equal(cols, want_c)
    with pytest.raises(ShapeMismatchError, match=r"\(48,\)"):
        mask_pixels(np.zeros(48, bool))


def test_lifted_view_points_of_any_mask_equal_the_whole_image_lift() -> None:
    """Whole masks and windows at a corner, blobs anywhere: ``LiftedView.points`` equals ``lift_depth``'s points at
    the mask's valid pixels, in row-major order."""
    from code_as_monitor.geometry.backproject import LiftedView, lift_depth

    rng = np.random.default_rng(7)
    depth = rng.uniform(0.3, 2.0, (48, 64)).astype(np.float32)
    depth[rng.random((48, 64)) < 0.15] = np.nan
    cam = _cam()
    pts, valid = lift_depth(depth, cam)
    lifted = LiftedView(depth, cam)
    for m in _scattered_masks(rng, (48, 64)):
        want = pts[m & valid]
        np.testing.assert_array_equal(lifted.points(m), want)
        np.testing.assert_array_equal(lifted.points(m[5:, 3:], (5, 3)), pts[5:, 3:][m[5:, 3:] & valid[5:, 3:]])
