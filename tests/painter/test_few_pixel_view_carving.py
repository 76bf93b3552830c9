"""A view that shows a part with too few pixels to add points still carves with the part's own pixels and its
siblings' (:mod:`code_as_monitor.painter.mask_elements`).

stow-book after the stow (`benchmarks/element_accuracy.py`, seeds 4 and 5): the book stands in its shelf, its spine
on the far side; the top view sees the spine's 1 x 2.4 cm top (about 20 pixels), the front view a few pixels of it.
The front view added no points, and its carving took the spine's own few pixels and the cover in front of it for
another object's surface: the spine could not grow down behind the cover, so the line lay across the top, 87-90
degrees off vertical, and the painter called it sound. Carving with the spine's pixels as its own and the cover as its
sibling, the sibling-free carving lets it run down behind the cover: the direction is open, the element weak.

Left alone (the same scene, seed 4 with one noise draw): 2 mm depth noise on the top's 21 points can tilt the fitted
patch 40 degrees, and nothing in the views says so; that line stays sound.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.bench.element_truth import element_errors, part_truth
from code_as_monitor.core import Constraint, ElementSpec, Observation, Phase, Subgoal, View
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.env import make_env

# the book's base pose after the scripted stow of stow-book seed 5 (position m, quaternion xyzw)
STOWED_SEED5 = ((0.44909, -0.21453, 0.10598), (-0.57149, 0.41632, 0.57157, 0.41639))
SPINE = ElementSpec("spine", "book", "spine", kind="line")


def _noisy(obs: Observation, sigma: float, seed: int) -> Observation:
    rng = np.random.default_rng(seed)
    views = {}
    for name, v in obs.views.items():
        d = v.depth.astype(np.float64)
        ok = d > 0
        d[ok] += rng.normal(0.0, sigma, int(ok.sum()))
        views[name] = View(v.rgb, d.astype(np.float32), v.camera, v.seg, v.seg_labels)
    return Observation(obs.t, views, obs.robot)


@pytest.fixture(scope="module")
def stowed():
    import pybullet as pb

    with make_env("stow-book", seed=5, disturbed=False) as env:
        w = env.world
        pb.resetBasePositionAndOrientation(w.objects["book"].bodies[0], *STOWED_SEED5, physicsClientId=w.client)
        yield w.observe(), part_truth(w, "book", "spine")


def _paint(obs: Observation):
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    res = painter.paint(obs, Subgoal("look", [Constraint("look", "see", Phase.UPON, [SPINE])]))
    return res.elements[0]


@pytest.mark.parametrize("draw", [None, 1, 2, 3, 4, 5, 6])
def test_a_spine_read_across_its_top_is_weak(stowed, draw) -> None:
    obs, truth = stowed
    e = _paint(obs if draw is None else _noisy(obs, 0.002, draw))
    off = element_errors("line", e.points, truth)["direction_deg"]
    assert e.support is not None
    assert off <= 10.0 or e.support.weak(), (off, e.support)


def test_the_view_adding_no_points_carves_with_the_parts_and_siblings_pixels(stowed, monkeypatch) -> None:
    import code_as_monitor.geometry as geometry

    obs, _ = stowed
    seen: list = []
    real = geometry.build_element_from_clouds

    def spy(eid, spec, clouds, views, support=None):
        seen.append((clouds, views))
        return real(eid, spec, clouds, views, support)

    monkeypatch.setattr(geometry, "build_element_from_clouds", spy)
    _paint(_noisy(obs, 0.002, 4))
    clouds, views = seen[-1]
    empty = [v for c, v in zip(clouds, views) if len(c) == 0]
    assert empty, "expected a view showing the spine too small to add points"
    for v in empty:
        assert v.mask.any() and v.siblings is not None and v.siblings.any()
        assert not (v.mask & v.siblings).any()
