"""fit_element_points on hand-made clouds, build_element / ee_element errors and options."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ElementError, GeometryError, NoValidDepthError, ShapeMismatchError
from code_as_monitor.geometry import (
    VOXEL_DIVISIONS,
    build_element,
    ee_element,
    element_voxel_size,
    fit_element_points,
    helpers,
    make_transform,
    rotation_about,
)

RNG = np.random.default_rng(7)


def _plane(nx: int = 60, ny: int = 40, size=(0.3, 0.2), noise: float = 0.001) -> np.ndarray:
    x, y = np.meshgrid(np.linspace(-size[0] / 2, size[0] / 2, nx), np.linspace(-size[1] / 2, size[1] / 2, ny))
    return np.c_[x.ravel(), y.ravel(), RNG.normal(0, noise, x.size)]


def test_surface_of_a_rotated_rectangle() -> None:
    R = rotation_about([1.0, 1.0, 0.0], 0.4) @ rotation_about([0, 0, 1], 0.3)
    P = _plane() @ R.T + [0.5, -0.2, 0.3]
    S = fit_element_points(P, "surface")
    assert S.shape == (4, 3)
    assert helpers.angle_between(helpers.normal(S), R[:, 2]) < np.deg2rad(1.0)
    corners = np.array([[0.15, 0.1, 0], [-0.15, 0.1, 0], [-0.15, -0.1, 0], [0.15, -0.1, 0]]) @ R.T + [0.5, -0.2, 0.3]
    d = np.linalg.norm(S[:, None] - corners[None], axis=2).min(axis=1)
    assert (d < 0.01).all()
    # counter-clockwise around the +z-oriented normal
    n = helpers.normal(S)
    assert all(np.cross(S[i] - S.mean(0), S[(i + 1) % 4] - S.mean(0)) @ n > 0 for i in range(4))


def test_surface_of_a_triangle_keeps_3_or_4_points() -> None:
    P = _plane(80, 80, (0.2, 0.2), 0.0)
    tri = P[P[:, 0] + P[:, 1] <= 0.0]  # lower-left half of the square
    S = fit_element_points(tri, ElementKind.SURFACE)
    assert S.shape[0] in (3, 4)
    assert helpers.point_in_polygon(np.array([-0.05, -0.05, 0.0]), S)
    assert not helpers.point_in_polygon(np.array([0.06, 0.06, 0.0]), S)


def test_line_and_point_of_a_noisy_segment() -> None:
    t = np.linspace(0.0, 1.0, 500)[:, None]
    d = np.array([0.6, 0.8, 0.0])
    P = t * 0.3 * d + RNG.normal(0, 0.001, (500, 3))
    L = fit_element_points(P, "line")
    assert helpers.angle_between(helpers.direction(L), d) < np.deg2rad(1.0)  # oriented: largest component > 0
    np.testing.assert_allclose(np.sort(L @ d), [0.0, 0.3], atol=0.005)
    p = fit_element_points(P, "point")
    assert p.shape == (1, 3)
    assert np.linalg.norm(p[0] - 0.15 * d) < 0.005


def test_dbscan_drops_debris() -> None:
    P = np.vstack([_plane(40, 40, (0.1, 0.1)), RNG.uniform(-0.5, 0.5, (15, 3)) + np.array([0.0, 0.0, 1.0])])
    p = fit_element_points(P, "point")
    assert np.linalg.norm(p[0]) < 0.005
    L = fit_element_points(np.vstack([_plane(100, 4, (0.3, 0.01)), [[2.0, 0.0, 0.0]]]), "line")
    assert np.abs(L[:, 0]).max() < 0.16


def test_element_voxel_size_follows_the_kind() -> None:
    P = _plane(size=(0.3, 0.2), noise=0.0)
    np.testing.assert_allclose(element_voxel_size(P, "surface")[:2], [0.15, 0.1], atol=1e-9)
    np.testing.assert_allclose(element_voxel_size(P, "line")[:2], [0.15, 0.2], atol=1e-9)
    np.testing.assert_allclose(element_voxel_size(P, "point")[:2], [0.3, 0.2], atol=1e-9)
    assert VOXEL_DIVISIONS[ElementKind.SURFACE] == (2, 2, 1)


def test_fit_errors_name_the_problem() -> None:
    with pytest.raises(ElementError, match="unknown element kind 'blob'"):
        fit_element_points(np.zeros((5, 3)), "blob")
    with pytest.raises(ElementError, match="no finite points"):
        fit_element_points(np.full((4, 3), np.nan), "point")
    with pytest.raises(ElementError, match=r"must be \(N, 3\)"):
        fit_element_points(np.zeros((4, 2)), "point")
    with pytest.raises(ElementError, match="coincide"):
        fit_element_points(np.zeros((20, 3)), "line")
    with pytest.raises(ElementError, match="collinear"):
        fit_element_points(np.c_[np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)], "surface")


def _cam() -> CameraModel:
    return CameraModel.look_at("c", [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], 32, 24, 60.0, up=[0, 1, 0])


def test_build_element_errors() -> None:
    cam = _cam()
    spec = ElementSpec("cup", "cup", "", ElementKind.POINT)
    mask = np.ones((24, 32), bool)
    with pytest.raises(ShapeMismatchError, match="mask shape"):
        build_element(0, spec, [(np.ones((24, 31), bool), np.ones((24, 32)), cam)])
    with pytest.raises(NoValidDepthError, match=r"'cup'.*'c'"):
        build_element(0, spec, [(mask, np.zeros((24, 32)), cam), (mask, np.full((24, 32), np.nan), cam)])
    with pytest.raises(NoValidDepthError, match="none"):
        build_element(0, spec, [])
    with pytest.raises(ElementError, match=r"'cup line'.*coincide"):  # one pixel cannot make a line
        build_element(0, ElementSpec("cup line", "cup", "", "line"), [(_one_px(), np.ones((24, 32)), cam)])
    e = build_element(2, spec, [(mask, np.ones((24, 32)), cam)])
    # a flat patch filling the image, seen from one side: centred under the camera, its hidden sides assumed
    np.testing.assert_allclose(e.points[0, :2], [0.0, 0.0], atol=0.03)
    assert e.support.assumed >= 1 and e.support.weak()  # its far side, and beyond the image borders


def _one_px() -> np.ndarray:
    m = np.zeros((24, 32), bool)
    m[12, 16] = True
    return m


def test_ee_element_from_point_and_pose() -> None:
    e = ee_element(5, "tip", np.array([0.1, 0.2, 0.3]))
    assert e.kind is ElementKind.POINT and e.owner == ("robot", "tip")
    np.testing.assert_allclose(e.points, [[0.1, 0.2, 0.3]])
    # a pose pointing its z axis down (a tool looking at the table), tip 5 cm along z
    T = make_transform(rotation_about([1, 0, 0], np.pi), [0.4, 0.0, 0.5])
    e = ee_element(1, "tip", T, tip_offset=[0, 0, 0.05])
    np.testing.assert_allclose(e.points[0], [0.4, 0.0, 0.45], atol=1e-12)
    L = ee_element(1, "tool", T, tip_offset=[0, 0, 0.05], axis_length=0.1, owner=("robot", "spatula"))
    assert L.kind is ElementKind.LINE and L.owner == ("robot", "spatula")
    np.testing.assert_allclose(L.points[1], [0.4, 0.0, 0.45], atol=1e-12)
    np.testing.assert_allclose(helpers.direction(L.points), [0, 0, -1], atol=1e-12)  # towards the tip


def test_ee_element_errors() -> None:
    with pytest.raises(ElementError, match="needs a"):
        ee_element(0, "tip", np.zeros(3), axis_length=0.1)
    with pytest.raises(GeometryError, match=r"\(3,\) point or a \(4, 4\) pose"):
        ee_element(0, "tip", np.zeros((3, 3)))
    with pytest.raises(GeometryError, match="not rigid"):
        ee_element(0, "tip", np.diag([1.0, 2.0, 1.0, 1.0]))
    with pytest.raises(ElementError, match="axis_length"):
        ee_element(0, "tip", np.eye(4), axis_length=0.0)
    with pytest.raises(ElementError, match="axis must be"):
        ee_element(0, "tip", np.eye(4), axis_length=0.1, axis=3)
