"""An analytic standing book for the line tests (ray-cast depth, exact masks), seen from the benchmark's front and
top cameras: 12 cm wide along x, 2.4 cm thick along y, 20 cm tall; its spine a 1 cm strip along one 20 cm edge (a
part), the rest the cover (its sibling)."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import Element, ElementKind, ElementSpec
from code_as_monitor.geometry import rotation_about
from code_as_monitor.geometry.backproject import backproject_mask
from code_as_monitor.geometry.carve import CarveView
from code_as_monitor.geometry.elements import build_element_from_clouds
from code_as_monitor.geometry.raycast import Box, Plane, cast
from code_as_monitor.geometry.support import support_plane

W, H = 320, 240
FRONT = CameraModel.look_at("front", np.array([1.15, 0.0, 0.65]), np.array([0.45, 0.0, 0.0]), W, H, 50.0)
TOP = CameraModel.look_at("top", np.array([0.5, 0.0, 1.5]), np.array([0.5, 0.0, 0.0]), W, H, 50.0)
CENTRE = np.array([0.5, 0.0, 0.1])


def book(side: float, yaw: float) -> tuple[np.ndarray, list]:
    """(R (3, 3), [spine, cover, table]) for the spine on the cover's +x (``side`` 1: facing the front camera) or -x
    (-1) side, the book turned ``yaw`` degrees about the vertical."""
    R = rotation_about([0.0, 0.0, 1.0], np.deg2rad(yaw))
    spine = Box(CENTRE + R @ np.array([side * 0.055, 0.0, 0.0]), np.array([0.005, 0.012, 0.1]), R)
    cover = Box(CENTRE + R @ np.array([-side * 0.005, 0.0, 0.0]), np.array([0.055, 0.012, 0.1]), R)
    return R, [spine, cover, Plane(0.0, (0.5, 0.0), (0.8, 0.8))]


def paint_spine(prims: list, noise_mm: float = 0.0, seed: int = 0) -> Element:
    """The spine's line element (``prims[0]`` the spine, ``prims[1]`` its cover, the rest other things), with
    ``noise_mm`` Gaussian depth noise."""
    rng = np.random.default_rng(seed)
    clouds, views, obs = [], [], []
    for cam in (FRONT, TOP):
        depth, index, _ = cast(prims, cam)
        d = np.where(np.isfinite(depth), depth, 0.0)
        if noise_mm > 0:
            d = np.where(d > 0, d + rng.normal(0.0, noise_mm / 1000.0, d.shape), 0.0)
        d = d.astype(np.float32)
        mask = index == 0
        clouds.append(backproject_mask(mask, d, cam, allow_empty=True))
        views.append(CarveView(mask, d, cam, siblings=index == 1))
        obs.append((d, cam))
    spec = ElementSpec("book spine", "book", "spine", ElementKind.LINE)
    return build_element_from_clouds(0, spec, clouds, views, support_plane(obs))


def off_vertical(points: np.ndarray) -> float:
    """Degrees between a line's points (2, 3) and the vertical."""
    d = points[1] - points[0]
    return float(np.degrees(np.arccos(abs(d[2]) / np.linalg.norm(d))))
