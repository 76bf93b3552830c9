"""The painter lifts a mask from the window its pixels span: the same points, in the same order, as the whole mask."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.geometry.backproject import LiftedView
from code_as_monitor.painter.mask_elements import _lift


def test_a_mask_lifted_from_its_window_equals_the_whole_mask_lifted() -> None:
    rng = np.random.default_rng(7)
    cam = CameraModel.look_at("c", np.array([0.5, 0.0, 0.8]), np.zeros(3), 64, 48, 60.0)
    depth = rng.uniform(0.3, 2.0, (48, 64)).astype(np.float32)
    depth[rng.random((48, 64)) < 0.15] = np.nan
    lifted = LiftedView(depth, cam)
    masks = [np.zeros((48, 64), bool), np.ones((48, 64), bool)]
    for r, c in ((0, 0), (47, 63), (0, 63), (47, 0)):  # a single pixel in each corner
        m = np.zeros((48, 64), bool)
        m[r, c] = True
        masks.append(m)
    for _ in range(20):  # scattered blobs anywhere
        m = np.zeros((48, 64), bool)
        r0, c0 = rng.integers(0, 40), rng.integers(0, 56)
        m[r0:r0 + rng.integers(1, 9), c0:c0 + rng.integers(1, 9)] = True
        m &= rng.random((48, 64)) < 0.7
        masks.append(m)
    for m in masks:
        got, want = _lift(lifted, m), lifted.points(m)
        assert got.shape == want.shape and np.array_equal(got, want)
