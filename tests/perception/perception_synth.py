"""A tiny analytic RGB-D renderer for perception tests: axis-aligned boxes on a textured table.

Every pixel's ray is intersected with the table plane z = 0 and with each box (slab method); the
nearest hit gives the depth (camera z, metres), the colour (a smooth random texture in the surface's
own coordinates, so it moves with its box) and the seg id. Box ids: ``10 + 2j`` body, ``11 + 2j`` top
face, labelled ``(name, "body")`` and ``(name, "top")``; the table is id 1 ``("table", "")``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.observation import Observation, RobotState, View

TEXELS_PER_M = 1000.0  # texture resolution: 1 mm per texel


def make_texture(seed: int, size: int = 512, sigma: float = 2.5) -> np.ndarray:
    """(size, size) float32 in [0, 1]: blurred uniform noise (LK-friendly, isotropic)."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.random((size, size)).astype(np.float32), (0, 0), sigma)
    t -= t.min()
    return t / max(float(t.max()), 1e-6)


@dataclass
class Box:
    """An axis-aligned box. centre (3,) world metres, size (3,) metres, colour RGB 0-255."""

    name: str
    center: np.ndarray
    size: np.ndarray
    color: tuple[int, int, int] = (200, 40, 40)
    textured: bool = True
    texture_seed: int = 1

    @property
    def lo(self) -> np.ndarray:
        return np.asarray(self.center, float) - np.asarray(self.size, float) / 2

    @property
    def hi(self) -> np.ndarray:
        return np.asarray(self.center, float) + np.asarray(self.size, float) / 2


@dataclass
class Scene:
    boxes: list[Box] = field(default_factory=list)
    table_color: tuple[int, int, int] = (128, 128, 128)
    table_textured: bool = True
    table_seed: int = 0

    def labels(self) -> dict[int, tuple[str, str]]:
        out = {1: ("table", "")}
        for j, b in enumerate(self.boxes):
            out[10 + 2 * j] = (b.name, "body")
            out[11 + 2 * j] = (b.name, "top")
        return out

    def poses(self) -> dict[str, np.ndarray]:
        out = {"table": np.eye(4)}
        for b in self.boxes:
            T = np.eye(4)
            T[:3, 3] = b.center
            out[b.name] = T
            Tt = T.copy()
            Tt[2, 3] += b.size[2] / 2
            out[f"{b.name}/top"] = Tt
        return out


_TEX_CACHE: dict[int, np.ndarray] = {}


def _tex(seed: int) -> np.ndarray:
    if seed not in _TEX_CACHE:
        _TEX_CACHE[seed] = make_texture(seed)
    return _TEX_CACHE[seed]


def _sample(seed: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bilinear sample of the periodic texture at surface coordinates (a, b), metres."""
    t = _tex(seed)
    n = t.shape[0]
    x, y = a * TEXELS_PER_M, b * TEXELS_PER_M
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = x - x0, y - y0
    i0, j0 = x0.astype(np.int64) % n, y0.astype(np.int64) % n
    i1, j1 = (i0 + 1) % n, (j0 + 1) % n
    return (t[j0, i0] * (1 - fx) + t[j0, i1] * fx) * (1 - fy) + (t[j1, i0] * (1 - fx) + t[j1, i1] * fx) * fy


def camera(
    name: str, eye, target=(0.0, 0.0, 0.02), width: int = 320, height: int = 240, fov: float = 50.0
) -> CameraModel:
    return CameraModel.look_at(name, np.asarray(eye, float), np.asarray(target, float), width, height, fov)


def render(scene: Scene, cam: CameraModel) -> View:
    """Render ``scene`` from ``cam`` into a View with rgb, depth (camera z, metres), seg and seg_labels."""
    H, W = cam.height, cam.width
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    Kinv = np.linalg.inv(cam.K)
    d_cam = np.stack([u, v, np.ones_like(u)], -1) @ Kinv.T  # z = 1 -> ray parameter = depth
    R = cam.T_world_cam[:3, :3]
    d = d_cam.reshape(-1, 3) @ R.T
    o = cam.T_world_cam[:3, 3]
    n = d.shape[0]
    depth = np.full(n, np.inf)
    seg = np.zeros(n, np.int32)
    rgb = np.zeros((n, 3), np.float64)

    # Table plane z = 0.
    with np.errstate(divide="ignore", invalid="ignore"):
        tt = -o[2] / d[:, 2]
    hit = np.isfinite(tt) & (tt > 0)
    depth[hit] = tt[hit]
    seg[hit] = 1
    p = o + tt[hit, None] * d[hit]
    shade = 0.7 + 0.3 * _sample(scene.table_seed, p[:, 0], p[:, 1]) if scene.table_textured else 1.0
    rgb[hit] = np.asarray(scene.table_color, float) * np.asarray(shade).reshape(-1, 1)

    for j, b in enumerate(scene.boxes):
        lo, hi = b.lo, b.hi
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (lo - o) / d
            t2 = (hi - o) / d
        tmin_ax = np.minimum(t1, t2)
        tmax = np.nanmin(np.maximum(t1, t2), axis=1)
        tmin_ax = np.nan_to_num(tmin_ax, nan=-np.inf)
        axis = np.argmax(tmin_ax, axis=1)
        tmin = tmin_ax[np.arange(n), axis]
        hitb = (tmax >= tmin) & (tmin > 0) & (tmin < depth)
        if not hitb.any():
            continue
        depth[hitb] = tmin[hitb]
        p = o + tmin[hitb, None] * d[hitb] - lo
        ax = axis[hitb]
        top = (ax == 2) & (d[hitb, 2] < 0)
        seg[hitb] = np.where(top, 11 + 2 * j, 10 + 2 * j)
        # In-face texture coordinates (box frame), offset per face so faces differ.
        a = np.where(ax == 0, p[:, 1], p[:, 0]) + 0.1 * ax
        c = np.where(ax == 2, p[:, 1], p[:, 2]) + 0.2 * ax
        if b.textured:
            shade = 0.45 + 0.55 * _sample(b.texture_seed, a, c)
        else:
            shade = np.where(top, 1.0, np.where(ax == 0, 0.8, 0.65))
        rgb[hitb] = np.asarray(b.color, float) * shade[:, None]

    depth[~np.isfinite(depth)] = 0.0
    return View(
        rgb=np.clip(rgb, 0, 255).astype(np.uint8).reshape(H, W, 3),
        depth=depth.astype(np.float32).reshape(H, W),
        camera=cam,
        seg=seg.reshape(H, W),
        seg_labels=scene.labels(),
    )


def observe(scene: Scene, cams: list[CameraModel], t: float, tip=None, with_poses: bool = True) -> Observation:
    """Render every camera; ``tip`` (3,) sets ``robot.ee_points["tip"]`` (ee_pose translated there)."""
    robot = None
    if tip is not None:
        T = np.eye(4)
        T[:3, 3] = tip
        robot = RobotState(ee_pose=T, ee_points={"tip": np.asarray(tip, float)})
    return Observation(
        t=t,
        views={c.name: render(scene, c) for c in cams},
        robot=robot,
        objects=["table", *[b.name for b in scene.boxes]],
        object_poses=scene.poses() if with_poses else None,
    )


def two_cameras(width: int = 320, height: int = 240, distance: float = 0.7) -> list[CameraModel]:
    """Two cameras ~``distance`` m from the origin, 45 and 50 degrees down, about 90 degrees apart;
    the field of view shrinks with distance so a 6 cm block stays ~40 px wide at 320 x 240."""
    fov = float(np.degrees(2 * np.arctan(0.18 / distance)))
    s = distance / np.sqrt(2.0)
    return [
        camera("front", (s, -0.1 * s, s), width=width, height=height, fov=fov),
        camera("side", (0.05 * s, s * np.cos(0.7), s * np.sin(0.7) * 1.2), width=width, height=height, fov=fov),
    ]
