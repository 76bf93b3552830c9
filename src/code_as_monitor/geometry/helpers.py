"""Geometry helpers available to monitor programs (and to everyone else).

These are the only functions, besides ``np`` and ``math``, that a generated monitor program may call.
Every argument is a NumPy array in the world frame (z up, metres); an element is passed as its
points ``(k, 3)``: a point element has k = 1, a line k = 2, a surface k = 3 or 4. Angles are radians.
Functions accept either a single point ``(3,)`` or an element ``(k, 3)`` where a point is expected
and use the element's centroid.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

_Z = np.array([0.0, 0.0, 1.0])


def _pt(p: np.ndarray) -> np.ndarray:
    """A single point (3,) from a point (3,) or an element (k, 3) (its centroid)."""
    a = np.asarray(p, dtype=np.float64)
    if a.ndim == 1:
        return a[:3]
    return a.reshape(-1, 3).mean(axis=0)


def centroid(P: np.ndarray) -> np.ndarray:
    """Centroid (3,) of points ``P`` (k, 3)."""
    return _pt(P)


def distance(a: np.ndarray, b: np.ndarray) -> float:
    """Euclidean distance in metres between two points or element centroids."""
    return float(np.linalg.norm(_pt(a) - _pt(b)))


def horizontal_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Distance in the xy plane (metres) between two points or element centroids."""
    d = _pt(a) - _pt(b)
    return float(math.hypot(d[0], d[1]))


def direction(L: np.ndarray) -> np.ndarray:
    """Unit direction (3,) of a line element ``L`` (2, 3), from its first to its second point."""
    L = np.asarray(L, dtype=np.float64).reshape(-1, 3)
    if L.shape[0] < 2:
        return _Z.copy()
    d = L[-1] - L[0]
    n = np.linalg.norm(d)
    return d / n if n > 1e-12 else _Z.copy()


def normal(S: np.ndarray) -> np.ndarray:
    """Unit normal (3,) of a surface element ``S`` (k >= 3, 3), oriented to have z >= 0.

    Fitted by SVD through all the points (the plane of least squares).
    """
    S = np.asarray(S, dtype=np.float64).reshape(-1, 3)
    if S.shape[0] < 3:
        return _Z.copy()
    _, _, vt = np.linalg.svd(S - S.mean(axis=0))
    n = vt[-1]
    return -n if n[2] < 0 else n


def angle_between(u: np.ndarray, v: np.ndarray) -> float:
    """Angle in radians, in [0, pi], between two direction vectors (3,)."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    nu, nv = np.linalg.norm(u), np.linalg.norm(v)
    if nu < 1e-12 or nv < 1e-12:
        return 0.0
    c = float(np.dot(u, v) / (nu * nv))
    return math.acos(max(-1.0, min(1.0, c)))


def angle_to_vertical(u: np.ndarray) -> float:
    """Angle in radians, in [0, pi/2], between the (unsigned) direction ``u`` and the world z axis."""
    a = angle_between(u, _Z)
    return min(a, math.pi - a)


def point_in_polygon(p: np.ndarray, poly: np.ndarray) -> bool:
    """True when point ``p`` lies inside polygon ``poly`` (k >= 3, 3), both projected on the xy plane.

    The polygon's points are taken in the order given, or in angular order around their centroid
    when that order self-intersects (so a surface element's 4 corner points work either way).
    """
    P = np.asarray(poly, dtype=np.float64).reshape(-1, 3)[:, :2]
    if P.shape[0] < 3:
        return False
    c = P.mean(axis=0)
    order = np.argsort(np.arctan2(P[:, 1] - c[1], P[:, 0] - c[0]))
    P = P[order]
    x, y = _pt(p)[:2]
    inside = False
    j = len(P) - 1
    for i in range(len(P)):
        xi, yi = P[i]
        xj, yj = P[j]
        if (yi > y) != (yj > y):
            x_cross = xi + (y - yi) * (xj - xi) / (yj - yi)
            if x < x_cross:
                inside = not inside
        j = i
    return inside


def count_in_polygon(points: list[np.ndarray] | np.ndarray, poly: np.ndarray) -> int:
    """How many of ``points`` (a list of points/elements, or an (N, 3) array) lie inside ``poly`` (xy)."""
    return int(sum(point_in_polygon(q, poly) for q in points))


def signed_height(p: np.ndarray, S: np.ndarray) -> float:
    """Signed distance (metres) of point ``p`` from the plane of surface ``S``; positive on the +normal side."""
    S = np.asarray(S, dtype=np.float64).reshape(-1, 3)
    return float(np.dot(_pt(p) - S.mean(axis=0), normal(S)))


def point_above_surface(p: np.ndarray, S: np.ndarray, margin: float = 0.0) -> bool:
    """True when ``p`` projects (xy) inside surface ``S`` and lies more than ``margin`` metres above its plane."""
    return point_in_polygon(p, S) and signed_height(p, S) > margin


def displacement(Hi: np.ndarray) -> float:
    """Net motion (metres) of an element's centroid over its history ``Hi`` (T, k, 3): |last - first|."""
    Hi = np.asarray(Hi, dtype=np.float64)
    if Hi.ndim != 3 or Hi.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(Hi[-1].mean(axis=0) - Hi[0].mean(axis=0)))


MONITOR_HELPERS: dict[str, Callable[..., object]] = {
    "distance": distance,
    "horizontal_distance": horizontal_distance,
    "centroid": centroid,
    "direction": direction,
    "normal": normal,
    "angle_between": angle_between,
    "angle_to_vertical": angle_to_vertical,
    "point_in_polygon": point_in_polygon,
    "count_in_polygon": count_in_polygon,
    "signed_height": signed_height,
    "point_above_surface": point_above_surface,
    "displacement": displacement,
}
"""Name -> function: the helpers a monitor program may call (documented in the coder prompt)."""
