"""A synthetic RGB-D scene with exact ground truth, for tests, benchmarks and ``cam elements``.

On a table (the plane z = 0) stand a box (parts ``top`` and ``body``), a plate tilted by 10 degrees
(parts ``surface``, its upper face, and ``rim``) and a rod tilted by 15 degrees (a capped cylinder, one
whole-object part ``""``), seen by two cameras. Depth is ray-cast analytically
(:mod:`~.raycast`), then corrupted on demand with Gaussian noise and outlier pixels.

Ground truth (:meth:`SyntheticScene.truth`), world metres:

- ``box``/``top`` and ``plate``/``surface`` as a point: the face centre (the visible centre of a
  fully visible symmetric face); as a surface: the face's four corners (counter-clockwise from +z).
- ``rod`` as a line: the two cap centres (its axis); as a point: its centre (on the axis, so a point
  *on* the rod's surface is at least ``ROD_RADIUS`` from it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ElementError
from code_as_monitor.core.observation import View
from code_as_monitor.geometry.raycast import Box, Cylinder, Plane, Primitive, cast
from code_as_monitor.geometry.transforms import rotation_about

BOX_HALF = 0.04
PLATE_HALF = (0.10, 0.07, 0.005)
PLATE_TILT_DEG = 10.0
ROD_RADIUS = 0.008
ROD_HALF_LENGTH = 0.13
ROD_TILT_DEG = 15.0

STANDARD_SPECS: tuple[ElementSpec, ...] = (
    ElementSpec("box top centre", "box", "top", ElementKind.POINT),
    ElementSpec("box top", "box", "top", ElementKind.SURFACE),
    ElementSpec("plate surface", "plate", "surface", ElementKind.SURFACE),
    ElementSpec("rod axis", "rod", "", ElementKind.LINE),
)
"""The elements ``cam elements`` builds and the tests check."""


@dataclass(frozen=True)
class SceneObject:
    """A named primitive; ``parts[face]`` names the part each face belongs to; ``color`` RGB uint8."""

    name: str
    shape: Primitive
    parts: tuple[str, ...]
    color: tuple[int, int, int]


@dataclass
class SyntheticScene:
    """Objects, cameras and the seg-id table: id ``i + 1`` per (object, part), 0 for nothing."""

    objects: list[SceneObject]
    cameras: list[CameraModel]

    def __post_init__(self) -> None:
        self.labels: dict[int, tuple[str, str]] = {}
        self._ids: dict[tuple[str, str], int] = {}
        for obj in self.objects:
            for part in dict.fromkeys(obj.parts):
                self._ids[(obj.name, part)] = len(self._ids) + 1
                self.labels[self._ids[(obj.name, part)]] = (obj.name, part)
        self._renders: dict[tuple[str, bytes, bytes], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def object(self, name: str) -> SceneObject:
        for o in self.objects:
            if o.name == name:
                return o
        raise ElementError(f"no object {name!r} in the synthetic scene; have {[o.name for o in self.objects]}")

    def render(self, camera: CameraModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise-free ``(rgb (H, W, 3) uint8, depth (H, W) float32 metres (0 = no hit), seg (H, W) int32)``.

        Cached per camera (the scene's objects are fixed); callers get copies.
        """
        key = (camera.name, camera.K.tobytes(), camera.T_world_cam.tobytes())
        if key not in self._renders:
            self._renders[key] = self._render(camera)
        return tuple(a.copy() for a in self._renders[key])  # type: ignore[return-value]

    def _render(self, camera: CameraModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        depth, index, face = cast([o.shape for o in self.objects], camera)
        seg = np.zeros(depth.shape, dtype=np.int32)
        rgb = np.full((*depth.shape, 3), 40, dtype=np.uint8)
        light = np.array([0.3, -0.4, 0.87])
        for i, obj in enumerate(self.objects):
            on = index == i
            if not on.any():
                continue
            normals = obj.shape.face_normals() if hasattr(obj.shape, "face_normals") else None
            for f, part in enumerate(obj.parts):
                sel = on & (face == f)
                seg[sel] = self._ids[(obj.name, part)]
                shade = 0.8 if normals is None else 0.5 + 0.5 * abs(float(normals[f] @ light))
                rgb[sel] = (np.array(obj.color) * shade).astype(np.uint8)
        depth = np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)
        return rgb, depth, seg

    def views(
        self, seed: int = 0, noise_mm: float = 2.0, outlier_frac: float = 0.01, max_depth: float = 5.0
    ) -> list[View]:
        """One :class:`View` per camera with noisy depth (see :func:`add_depth_noise`) and seg ids."""
        rng = np.random.default_rng(seed)
        out = []
        for cam in self.cameras:
            rgb, depth, seg = self.render(cam)
            table_id = self._ids.get(("table", ""), -1)
            objects = (seg > 0) & (seg != table_id)
            noisy = add_depth_noise(depth, objects, rng, noise_mm / 1000.0, outlier_frac, max_depth)
            out.append(View(rgb, noisy, cam, seg, dict(self.labels)))
        return out

    def truth(self, spec: ElementSpec) -> np.ndarray:
        """Ground-truth points (k, 3) of ``spec`` (see the module docstring); ElementError if undefined."""
        key = (spec.obj, spec.part, spec.kind)
        if spec.obj in ("box", "plate") and spec.part in ("top", "surface"):
            shape = self.object(spec.obj).shape
            assert isinstance(shape, Box)
            corners = shape.corners(4)
            if spec.kind is ElementKind.SURFACE:
                return corners
            if spec.kind is ElementKind.POINT:
                return corners.mean(axis=0, keepdims=True)
        if spec.obj == "rod":
            shape = self.object("rod").shape
            assert isinstance(shape, Cylinder)
            if spec.kind is ElementKind.LINE:
                return shape.ends()
            if spec.kind is ElementKind.POINT:
                return shape.center[None].copy()
        raise ElementError(f"the synthetic scene has no ground truth for {key}")


def add_depth_noise(
    depth: np.ndarray,
    outlier_mask: np.ndarray,
    rng: np.random.Generator,
    sigma: float = 0.002,
    outlier_frac: float = 0.01,
    max_depth: float = 5.0,
    outlier_range: tuple[float, float] = (0.2, 2.5),
) -> np.ndarray:
    """Noisy copy (H, W) float32 of ``depth``: Gaussian noise ``sigma`` metres on every valid reading,
    and ``outlier_frac`` of the pixels of ``outlier_mask`` (H, W) given a uniformly random wrong depth
    in ``outlier_range`` metres. Missing readings (0) stay missing."""
    d = depth.astype(np.float64)
    valid = (d > 0) & (d <= max_depth)
    if sigma > 0:
        d[valid] += rng.normal(0.0, sigma, size=int(valid.sum()))
    cand = np.flatnonzero(outlier_mask & valid)
    n_out = round(outlier_frac * len(cand))
    if n_out > 0:
        pick = rng.choice(cand, size=n_out, replace=False)
        d.reshape(-1)[pick] = rng.uniform(*outlier_range, size=n_out)
    return d.astype(np.float32)


def make_scene(
    width: int = 640, height: int = 480, distance: float = 0.75, fov_y_deg: float = 50.0
) -> SyntheticScene:
    """The standard scene: box, plate and rod on a table, two cameras ``distance`` metres from the centre.

    Cameras look at (0.03, 0.0, 0.04) from the front-right and front-left at about 40 degrees elevation.
    """
    z = np.array([0.0, 0.0, 1.0])
    box = Box(np.array([0.0, 0.0, BOX_HALF]), np.full(3, BOX_HALF), rotation_about(z, np.deg2rad(25.0)))
    R_plate = rotation_about(z, np.deg2rad(-15.0)) @ rotation_about([1.0, 0.0, 0.0], np.deg2rad(PLATE_TILT_DEG))
    plate = Box(np.array([0.03, 0.2, 0.04]), np.array(PLATE_HALF), R_plate)
    tilt, yaw = np.deg2rad(ROD_TILT_DEG), np.deg2rad(30.0)
    rod_axis = np.array([np.cos(tilt) * np.cos(yaw), np.cos(tilt) * np.sin(yaw), np.sin(tilt)])
    rod = Cylinder(np.array([0.06, -0.18, 0.05]), rod_axis, ROD_RADIUS, ROD_HALF_LENGTH)
    table = Plane(0.0, (0.0, 0.0), (0.8, 0.8))
    objects = [
        SceneObject("box", box, ("body", "body", "body", "body", "top", "body"), (220, 40, 40)),
        SceneObject("plate", plate, ("rim", "rim", "rim", "rim", "surface", "rim"), (40, 160, 60)),
        SceneObject("rod", rod, ("", "", ""), (40, 80, 220)),
        SceneObject("table", table, ("",), (170, 150, 120)),
    ]
    target = np.array([0.03, 0.0, 0.04])
    cams = []
    for name, az in (("right", -35.0), ("left", -125.0)):
        a, el = np.deg2rad(az), np.deg2rad(40.0)
        eye = target + distance * np.array([np.cos(el) * np.cos(a), np.cos(el) * np.sin(a), np.sin(el)])
        cams.append(CameraModel.look_at(name, eye, target, width, height, fov_y_deg))
    return SyntheticScene(objects, cams)


def element_errors(kind: ElementKind | str, points: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    """Errors of an estimated element (k, 3) against its ground truth (world metres).

    Returns, by kind: point ``{"position_mm"}``; line ``{"direction_deg", "ends_mm"}`` (direction
    unsigned, ends matched in the better order, mean); surface ``{"normal_deg", "corners_mm"}`` (mean
    distance from each estimated point to the nearest true corner).
    """
    kind = ElementKind.parse(kind)
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    T = np.asarray(truth, dtype=np.float64).reshape(-1, 3)
    if kind is ElementKind.POINT:
        return {"position_mm": 1000.0 * float(np.linalg.norm(P[0] - T[0]))}
    if kind is ElementKind.LINE:
        u, v = P[1] - P[0], T[1] - T[0]
        cos = abs(float(u @ v)) / max(float(np.linalg.norm(u) * np.linalg.norm(v)), 1e-12)
        d = np.linalg.norm(P[:, None] - T[None], axis=2)
        ends = min(d[0, 0] + d[1, 1], d[0, 1] + d[1, 0]) / 2.0
        return {"direction_deg": float(np.degrees(np.arccos(min(1.0, cos)))), "ends_mm": 1000.0 * float(ends)}

    def _normal(S: np.ndarray) -> np.ndarray:
        n = np.linalg.svd(S - S.mean(axis=0))[2][-1]
        return n / np.linalg.norm(n)

    cos = abs(float(_normal(P) @ _normal(T)))
    corners = np.linalg.norm(P[:, None] - T[None], axis=2).min(axis=1).mean()
    return {"normal_deg": float(np.degrees(np.arccos(min(1.0, cos)))), "corners_mm": 1000.0 * float(corners)}
