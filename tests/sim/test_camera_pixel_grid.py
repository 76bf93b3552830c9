"""A simulated camera's model is the one its images were rendered with, to the pixel grid.

Blocks of known pose are rendered; the pixels whose centres the model projects inside each block's silhouette
(the convex hull of its eight projected corners) must be its rendered mask, and the depth lifted through the
model must lie on the block's true faces. Before the TinyRenderer's half-pixel shift was put into the model
(``sim.cameras.PIXEL_SHIFT``) about one pixel in five of a block's mask and silhouette disagreed and the faces
seen by the front view read 1-2 mm off.
"""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.path import Path
from scipy.spatial import ConvexHull

from code_as_monitor.bench.element_truth import part_truth
from code_as_monitor.geometry.backproject import backproject_mask
from code_as_monitor.sim.cameras import PIXEL_SHIFT, CameraSpec, SimCamera, shifted_principal_point
from code_as_monitor.sim.env import make_env

BLOCKS = ("red_block", "green_block", "blue_block")
CAMERAS = (  # sizes odd and even, fields of view and eyes none of the tasks use
    CameraSpec("a", eye=(1.1, 0.2, 0.7), target=(0.45, 0.0, 0.0), width=640, height=480, fov_y_deg=50.0),
    CameraSpec("b", eye=(0.6, -0.45, 0.5), target=(0.45, 0.05, 0.0), width=201, height=151, fov_y_deg=70.0),
    CameraSpec("c", eye=(0.45, 0.02, 1.2), target=(0.45, 0.0, 0.0), width=321, height=241, fov_y_deg=38.0,
               up=(1.0, 0.0, 0.0)),
)


@pytest.fixture(scope="module")
def scene():
    with make_env("stack-in-order", seed=5, disturbed=False) as env:
        w = env.world
        views = [SimCamera(s, w.client, w.renderer).render(w.seg_labels()) for s in CAMERAS]
        yield views, {n: part_truth(w, n) for n in BLOCKS}


def _corners(t) -> np.ndarray:
    c = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return t.centre + (c * t.extent / 2.0) @ t.axes


def _mask(view, name: str) -> np.ndarray:
    ids = [k for k, lab in view.seg_labels.items() if lab[0] == name]
    return np.isin(view.seg, ids)


def _mismatch(view, camera, t, mask: np.ndarray) -> int:
    uv, _ = camera.project(_corners(t))
    hull = Path(uv[ConvexHull(uv).vertices])
    u0, v0 = np.floor(uv.min(axis=0)).astype(int) - 2
    u1, v1 = np.ceil(uv.max(axis=0)).astype(int) + 3
    U, V = np.meshgrid(np.arange(u0, u1), np.arange(v0, v1))
    inside = hull.contains_points(np.c_[U.ravel(), V.ravel()]).reshape(U.shape)
    return int((inside != mask[v0:v1, u0:u1]).sum())


@pytest.mark.parametrize("i", range(len(CAMERAS)))
def test_rendered_masks_are_the_projected_silhouettes(scene, i: int) -> None:
    views, truth = scene
    v = views[i]
    for name in BLOCKS:
        m = _mask(v, name)
        assert m.sum() > 30, f"{name} not seen by camera {v.camera.name}"
        # a pixel may disagree where an edge passes within float precision of its centre; not a whole row
        assert _mismatch(v, v.camera, truth[name], m) <= 2, (name, v.camera.name)


def test_without_the_shift_the_silhouettes_are_off(scene) -> None:
    """The check above can fail: the model without the renderer's shift misses by hundreds of pixels."""
    views, truth = scene
    du, dv = PIXEL_SHIFT["tiny"]
    v = views[0]
    plain = shifted_principal_point(v.camera, -du, -dv)
    assert sum(_mismatch(v, plain, truth[n], _mask(v, n)) for n in BLOCKS) > 100


@pytest.mark.parametrize("i", range(len(CAMERAS)))
def test_lifted_depth_lies_on_the_true_faces(scene, i: int) -> None:
    """Every mask pixel lifted through the model is on the block's surface (within 0.3 mm of a face plane)."""
    views, truth = scene
    v = views[i]
    for name in BLOCKS:
        t = truth[name]
        m = _mask(v, name)
        # away from the silhouette's border (a border pixel's depth may come from the block's edge)
        m &= np.roll(m, 1, 0) & np.roll(m, -1, 0) & np.roll(m, 1, 1) & np.roll(m, -1, 1)
        L = (backproject_mask(m, v.depth, v.camera) - t.centre) @ t.axes.T  # in the block's frame
        off = np.min(np.abs(np.abs(L) - t.extent / 2.0), axis=1)  # distance to the nearest face plane
        assert np.percentile(off, 95) < 3e-4, (name, v.camera.name, float(np.percentile(off, 95)))
