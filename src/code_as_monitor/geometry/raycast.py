"""Analytic ray casting of boxes, finite planes and capped cylinders (for synthetic depth images).

Rays share one origin ``o`` (3,) (the camera centre) and have world directions ``D`` (N, 3) scaled so
that their camera-frame z component is 1: the hit parameter ``t`` is then the depth along the optical
axis, exactly what a depth camera reports. Every intersector returns ``t`` (N,) (``inf`` on a miss) and
an int face index (N,) per ray (-1 on a miss), plus :func:`face_normals` for shading.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.camera import CameraModel

_EPS = 1e-9


@dataclass(frozen=True)
class Box:
    """Oriented box: ``center`` (3,), ``half`` (3,) half extents along its local axes, ``R`` (3, 3) local->world.

    Faces: 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z (local axes).
    """

    center: np.ndarray
    half: np.ndarray
    R: np.ndarray = field(default_factory=lambda: np.eye(3))

    def intersect(self, o: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ol = (o - self.center) @ self.R  # R^T (o - c)
        Dl = D @ self.R
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-self.half - ol) / Dl
            t2 = (self.half - ol) / Dl
        tn = np.nan_to_num(np.minimum(t1, t2), nan=-np.inf)
        tf = np.nan_to_num(np.maximum(t1, t2), nan=np.inf)
        axis = np.argmax(tn, axis=1)
        t_in = tn[np.arange(len(D)), axis]
        t_out = tf.min(axis=1)
        hit = (t_in <= t_out) & (t_in > _EPS)
        sign_pos = Dl[np.arange(len(D)), axis] < 0  # entering through the +face when moving towards -axis
        face = np.where(hit, 2 * axis + (~sign_pos).astype(np.int64), -1)
        return np.where(hit, t_in, np.inf), face

    def face_normals(self) -> np.ndarray:
        """(6, 3) world outward normals, indexed by face."""
        return np.stack([s * self.R[:, a] for a in range(3) for s in (1.0, -1.0)])

    def corners(self, face: int) -> np.ndarray:
        """(4, 3) world corners of ``face``, counter-clockwise seen from outside."""
        a, s = divmod(face, 2)
        sgn = 1.0 if s == 0 else -1.0
        b, c = (a + 1) % 3, (a + 2) % 3
        pts = []
        for u, v in ((1, 1), (-1, 1), (-1, -1), (1, -1)):
            p = np.zeros(3)
            p[a] = sgn * self.half[a]
            p[b] = u * self.half[b]
            p[c] = v * sgn * self.half[c]
            pts.append(self.center + self.R @ p)
        return np.array(pts)


@dataclass(frozen=True)
class Plane:
    """The finite rectangle ``|x - cx| <= hx, |y - cy| <= hy`` of the plane z = ``z`` (a table). Face 0."""

    z: float = 0.0
    center_xy: tuple[float, float] = (0.0, 0.0)
    half_xy: tuple[float, float] = (1.0, 1.0)

    def intersect(self, o: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (self.z - o[2]) / D[:, 2]
        x = o[0] + t * D[:, 0]
        y = o[1] + t * D[:, 1]
        hit = (
            np.isfinite(t) & (t > _EPS)
            & (np.abs(x - self.center_xy[0]) <= self.half_xy[0])
            & (np.abs(y - self.center_xy[1]) <= self.half_xy[1])
        )
        return np.where(hit, t, np.inf), np.where(hit, 0, -1)

    def face_normals(self) -> np.ndarray:
        return np.array([[0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Cylinder:
    """Capped cylinder: ``center`` (3,), unit ``axis`` (3,), ``radius``, ``half_length`` (metres).

    Faces: 0 side, 1 cap at +axis, 2 cap at -axis.
    """

    center: np.ndarray
    axis: np.ndarray
    radius: float
    half_length: float

    def intersect(self, o: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a = self.axis / np.linalg.norm(self.axis)
        oc = o - self.center
        oa = float(oc @ a)
        da = D @ a
        o_perp = oc - oa * a
        d_perp = D - da[:, None] * a
        A = np.einsum("ij,ij->i", d_perp, d_perp)
        B = 2.0 * (d_perp @ o_perp)
        C = float(o_perp @ o_perp) - self.radius**2
        disc = B * B - 4.0 * A * C
        with np.errstate(divide="ignore", invalid="ignore"):
            ts = (-B - np.sqrt(np.maximum(disc, 0.0))) / (2.0 * A)
        side_ok = (disc >= 0) & (A > _EPS) & (ts > _EPS) & (np.abs(oa + ts * da) <= self.half_length)
        t = np.where(side_ok, ts, np.inf)
        face = np.where(side_ok, 0, -1)
        for f, s in ((1, 1.0), (2, -1.0)):
            with np.errstate(divide="ignore", invalid="ignore"):
                tc = (s * self.half_length - oa) / da
                q = o_perp + tc[:, None] * d_perp
            ok = np.isfinite(tc) & (tc > _EPS) & (np.einsum("ij,ij->i", q, q) <= self.radius**2) & (tc < t)
            t = np.where(ok, tc, t)
            face = np.where(ok, f, face)
        return t, face

    def ends(self) -> np.ndarray:
        """(2, 3) world centres of the caps, -axis end first."""
        a = self.axis / np.linalg.norm(self.axis)
        return np.stack([self.center - self.half_length * a, self.center + self.half_length * a])


Primitive = Box | Plane | Cylinder


def camera_rays(camera: CameraModel) -> tuple[np.ndarray, np.ndarray]:
    """Origin (3,) and world ray directions (H*W, 3), row-major pixels, camera-frame z = 1."""
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    pix = np.stack([u.ravel(), v.ravel(), np.ones(u.size)], axis=1).astype(np.float64)
    d_cam = pix @ np.linalg.inv(camera.K).T
    d_cam /= d_cam[:, 2:3]
    R = camera.T_world_cam[:3, :3]
    return camera.T_world_cam[:3, 3].copy(), d_cam @ R.T


def cast(primitives: list[Primitive], camera: CameraModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Render ``primitives`` from ``camera``.

    Returns:
        depth: (H, W) float64 metres along the optical axis, ``inf`` where nothing is hit.
        index: (H, W) int index of the nearest primitive hit, -1 for none.
        face: (H, W) int face of that primitive, -1 for none.
    """
    o, D = camera_rays(camera)
    n = len(D)
    depth = np.full(n, np.inf)
    index = np.full(n, -1, dtype=np.int64)
    face = np.full(n, -1, dtype=np.int64)
    for i, prim in enumerate(primitives):
        t, f = prim.intersect(o, D)
        closer = t < depth
        depth = np.where(closer, t, depth)
        index = np.where(closer, i, index)
        face = np.where(closer, f, face)
    shape = (camera.height, camera.width)
    return depth.reshape(shape), index.reshape(shape), face.reshape(shape)
