"""Ground truth for constraint elements in the simulator, and the errors of an element against it.

What "true" means here (the benchmarks and tests score elements against this; the painter never sees it):

- A part's geometry is the set of its *visual* shapes (boxes, spheres, cylinders) as PyBullet reports them
  (``getVisualShapeData``: each shape's frame relative to its link's URDF frame). Visual shapes are what the
  cameras render and the masks cover; for every asset here they coincide with the collision shapes, except the
  pen tip's collision box, 2 mm thinner than its visual one with the same centre.
- The part's **true centre** is the centre of the bounding box of those shapes in the part's own link frame
  (for a box: its centre; for a hollow rim or a trough: the centre of the box that encloses it). A whole object
  (part ``""``) uses every link labelled with that object, boxed in the frame of its first body's base link.
- The part's **axes** are that frame's axes ordered by the box's extent, largest first: a LINE's true direction
  is the first axis, a SURFACE's true normal the last (the thinnest) one.

Errors (:func:`element_errors`): a point's distance to the true centre; a line's angle to the true direction and
the true centre's distance from the line (its axis offset); a surface's normal angle, the true centre's distance
from the plane (plane offset) and the distance of the surface points' mean from the true centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.elements import ElementKind

_BOX, _SPHERE, _CYLINDER, _CAPSULE = 3, 2, 4, 7  # PyBullet geometry type codes


@dataclass(frozen=True)
class PartTruth:
    """A part's true box. ``centre`` (3,) world metres; ``axes`` (3, 3) rows, world unit vectors, the box's
    axes by extent (largest first); ``extent`` (3,) metres along them."""

    centre: np.ndarray
    axes: np.ndarray
    extent: np.ndarray

    @property
    def direction(self) -> np.ndarray:
        return self.axes[0]

    @property
    def normal(self) -> np.ndarray:
        return self.axes[2]


def _quat_matrix(q) -> np.ndarray:
    import pybullet as pb

    return np.asarray(pb.getMatrixFromQuaternion(q), dtype=np.float64).reshape(3, 3)


def _link_frame(client: int, body: int, link: int) -> tuple[np.ndarray, np.ndarray]:
    """(R (3, 3), t (3,)) of the URDF frame of ``link`` (-1: base) in the world."""
    import pybullet as pb

    if link >= 0:
        st = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)
        return _quat_matrix(st[5]), np.asarray(st[4], dtype=np.float64)
    pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=client)
    info = pb.getDynamicsInfo(body, -1, physicsClientId=client)  # base inertial frame in the URDF base frame
    R_wi, t_wi = _quat_matrix(orn), np.asarray(pos, dtype=np.float64)
    R_bi, t_bi = _quat_matrix(info[4]), np.asarray(info[3], dtype=np.float64)
    R = R_wi @ R_bi.T
    return R, t_wi - R @ t_bi


def _shape_points(shape) -> np.ndarray:
    """Corner-like points (n, 3) of one visual shape in its own frame, enough to bound it."""
    kind, dims = shape[2], shape[3]
    if kind == _BOX:
        h = np.asarray(dims[:3], dtype=np.float64) / 2.0
        return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h
    if kind == _SPHERE:
        r = float(dims[0])
        return np.vstack([np.eye(3) * r, -np.eye(3) * r])
    if kind in (_CYLINDER, _CAPSULE):
        length, r = float(dims[0]), float(dims[1])
        half = length / 2.0 + (r if kind == _CAPSULE else 0.0)
        return np.array([[sx * r, sy * r, sz * half] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    raise ValueError(f"shape type {kind} is not supported by the element ground truth")


def part_truth(world, obj: str, part: str = "") -> PartTruth:
    """The true box of ``obj`` (``part`` ``""``: the whole object) in ``world`` (a :class:`sim.world.World`)."""
    import pybullet as pb

    c = world.client
    o = world.objects[obj]
    links = [o.parts[part]] if part else list(dict.fromkeys([*o.whole, *o.parts.values()]))
    ref_body, ref_link = links[0] if part else (o.bodies[0], -1)
    R0, t0 = _link_frame(c, ref_body, ref_link)
    pts = []
    for body in dict.fromkeys(b for b, _ in links):
        wanted = {lk for b, lk in links if b == body}
        for shape in pb.getVisualShapeData(body, physicsClientId=c):
            if shape[1] not in wanted:
                continue
            R_l, t_l = _link_frame(c, body, shape[1])
            R_s = _quat_matrix(shape[6])
            P = _shape_points(shape) @ R_s.T + np.asarray(shape[5], dtype=np.float64)
            pts.append((P @ R_l.T + t_l - t0) @ R0)  # in the reference frame
    if not pts:
        raise ValueError(f"{obj}/{part or '*'} has no visual shape")
    P = np.vstack(pts)
    lo, hi = P.min(axis=0), P.max(axis=0)
    ext = hi - lo
    order = np.argsort(-ext, kind="stable")
    centre = R0 @ ((lo + hi) / 2.0) + t0
    return PartTruth(centre, R0.T[order], ext[order])


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    c = abs(float(np.dot(a, b))) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-12)
    return math.degrees(math.acos(min(1.0, c)))


def surface_normal(points: np.ndarray) -> np.ndarray:
    """Unit normal (3,) of the least-squares plane through a surface element's points (k, 3)."""
    X = points - points.mean(axis=0)
    return np.linalg.svd(X)[2][2]


def element_errors(kind: ElementKind | str, points: np.ndarray, truth: PartTruth) -> dict[str, float]:
    """Errors of an element's points (k, 3) world metres against ``truth``; metres and degrees.

    point: ``point`` (distance to the centre); line: ``direction_deg``, ``axis_offset``; surface:
    ``normal_deg``, ``plane_offset``, ``centre``.
    """
    kind = ElementKind.parse(kind)
    P = np.asarray(points, dtype=np.float64)
    if kind is ElementKind.POINT:
        return {"point": float(np.linalg.norm(P[0] - truth.centre))}
    if kind is ElementKind.LINE:
        d = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
        x = truth.centre - P[0]
        return {"direction_deg": _angle_deg(d, truth.direction),
                "axis_offset": float(np.linalg.norm(x - np.dot(x, d) * d))}
    n = surface_normal(P)
    return {"normal_deg": _angle_deg(n, truth.normal),
            "plane_offset": abs(float(np.dot(truth.centre - P.mean(axis=0), n))),
            "centre": float(np.linalg.norm(P.mean(axis=0) - truth.centre))}
