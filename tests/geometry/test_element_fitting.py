"""The element pipeline on the analytic scene (2 mm depth noise, 1 % outlier pixels), over seeds.

Ground truth (see ``code_as_monitor.geometry.synthetic``):
- a point of a solid (the box, the rod) is its centre;
- a line is the rod's axis (cap centre to cap centre), judged by direction and ends;
- a surface is the face's plane (normal) and corners.
Tolerances: 8 mm for points (the issue's target for any point element), 3 degrees for directions and normals.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.observation import View
from code_as_monitor.geometry import build_element, helpers
from code_as_monitor.geometry.synthetic import ROD_RADIUS, SyntheticScene

DEG = np.pi / 180.0
SEEDS = (0, 1, 2, 3)


def _build(views: list[View], spec: ElementSpec, id: int = 0):
    return build_element(id, spec, [(v.mask_of(spec.obj, spec.part), v.depth, v.camera) for v in views])


def _area(poly: np.ndarray, n: np.ndarray) -> float:
    """Signed area of a planar polygon (k, 3) in its given order, seen from the +n side."""
    return 0.5 * float(sum(np.cross(poly[i], poly[(i + 1) % len(poly)]) @ n for i in range(len(poly))))


@pytest.mark.parametrize("seed", SEEDS)
def test_point_of_a_solid_is_its_centre(
    scene: SyntheticScene, noisy_views: Callable[[int], list[View]], seed: int
) -> None:
    """A whole box on the table as a point: its centre, not the centroid of its visible skin (which lies about
    half the box, 4 cm here, towards the cameras). Tolerance: the issue's 8 mm target for any point element."""
    e = _build(noisy_views(seed), ElementSpec("box", "box"), id=3)
    assert e.points.shape == (1, 3) and e.owner == ("box", "") and e.id == 3
    box = scene.object("box").shape
    assert np.linalg.norm(e.points[0] - box.center) < 0.008
    skin = _build_cloud(scene, "box").mean(axis=0)
    assert np.linalg.norm(skin - box.center) > 0.008  # a skin centroid would fail this test
    assert e.support.views == 2 and e.support.points > 100 and e.support.residual < 0.005


def _build_cloud(scene: SyntheticScene, obj: str) -> np.ndarray:
    from code_as_monitor.geometry import part_cloud

    views = scene.views(seed=0, noise_mm=0.0, outlier_frac=0.0)
    P, _ = part_cloud([(v.mask_of(obj), v.depth, v.camera) for v in views])
    return P


@pytest.mark.parametrize("seed", SEEDS)
def test_rod_point_is_on_the_rod_near_its_centre(
    scene: SyntheticScene, noisy_views: Callable[[int], list[View]], seed: int
) -> None:
    spec = ElementSpec("rod", "rod", "", ElementKind.POINT)
    e = _build(noisy_views(seed), spec)
    # truth is the axis centre (a point on the rod's surface would be ROD_RADIUS from it)
    assert np.linalg.norm(e.points[0] - scene.truth(spec)[0]) < 0.008


@pytest.mark.parametrize("seed", SEEDS)
def test_rod_line_direction_within_3_degrees(
    scene: SyntheticScene, noisy_views: Callable[[int], list[View]], seed: int
) -> None:
    spec = ElementSpec("rod axis", "rod", "", ElementKind.LINE)
    e = _build(noisy_views(seed), spec)
    truth = scene.truth(spec)
    a = helpers.angle_between(helpers.direction(e.points), helpers.direction(truth))
    assert min(a, np.pi - a) < 3 * DEG
    # the ends are the rod's ends (in either order), within a rod diameter
    d = np.linalg.norm(e.points[:, None] - truth[None], axis=2)
    assert min(d[0, 0] + d[1, 1], d[0, 1] + d[1, 0]) < 2 * 2 * ROD_RADIUS


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize(("obj", "part"), [("box", "top"), ("plate", "surface"), ("plate", "")])
def test_surface_normal_within_3_degrees_and_spans_the_face(
    scene: SyntheticScene, noisy_views: Callable[[int], list[View]], seed: int, obj: str, part: str
) -> None:
    spec = ElementSpec(f"{obj} {part}", obj, part, ElementKind.SURFACE)
    e = _build(noisy_views(seed), spec)
    truth = scene.truth(ElementSpec("t", obj, "top" if obj == "box" else "surface", ElementKind.SURFACE))
    n_true = helpers.normal(truth)
    assert e.points.shape[0] in (3, 4)
    assert helpers.angle_between(helpers.normal(e.points), n_true) < 3 * DEG
    # boundary order: counter-clockwise seen from above, not self-intersecting, and spanning the face
    true_area = _area(truth, n_true)
    assert 0.8 * true_area < _area(e.points, n_true) < 1.05 * true_area
    assert helpers.point_in_polygon(truth.mean(axis=0), e.points)
    for p in e.points:  # each element point is near a true corner
        assert np.linalg.norm(truth - p, axis=1).min() < 0.015


def test_elements_of_standard_specs_are_numbered_and_coloured(noisy_views: Callable[[int], list[View]]) -> None:
    from code_as_monitor.core.elements import color_for
    from code_as_monitor.geometry.synthetic import STANDARD_SPECS

    views = noisy_views(0)
    for i, spec in enumerate(STANDARD_SPECS):
        e = _build(views, spec, id=i)
        assert e.kind is spec.kind and e.color == color_for(i)


def test_a_view_that_does_not_see_the_part_is_skipped(
    scene: SyntheticScene, noisy_views: Callable[[int], list[View]]
) -> None:
    """An empty mask adds no points; its depth still says where the part is not (8 mm: the point target)."""
    views = noisy_views(1)
    spec = ElementSpec("box", "box", "", ElementKind.POINT)
    v0 = views[0]
    obs = [(np.zeros_like(v0.depth, dtype=bool), v0.depth, v0.camera)]
    obs += [(v.mask_of("box"), v.depth, v.camera) for v in views[1:]]
    e = build_element(0, spec, obs)
    assert e.support.views == 1
    assert np.linalg.norm(e.points[0] - scene.object("box").shape.center) < 0.008
