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
    a = a.reshape(-1, 3)
    if a.shape[0] == 1:  # a point element: its one point (a copy, as the mean would be)
        return a[0].copy()
    return np.add.reduce(a, 0) / a.shape[0]  # what ``mean(axis=0)`` computes, without its Python wrapper


def _norm(v: np.ndarray) -> float:
    """Euclidean norm of a vector (3,): what ``np.linalg.norm`` computes for it, at a third of the cost."""
    return math.sqrt(float(v.dot(v)))


def centroid(P: np.ndarray) -> np.ndarray:
    """Centroid (3,) of points ``P`` (k, 3)."""
    return _pt(P)


def distance(a: np.ndarray, b: np.ndarray) -> float:
    """Euclidean distance in metres between two points or element centroids."""
    return _norm(_pt(a) - _pt(b))


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
    n = _norm(d)
    return d / n if n > 1e-12 else _Z.copy()


def normal(S: np.ndarray) -> np.ndarray:
    """Unit normal (3,) of a surface element ``S`` (k >= 3, 3), oriented to have z >= 0.

    The plane of least squares through all the points: for exactly three points that are not collinear,
    the cross product of two edges; for more, the closed form of :func:`_least_squares_normal`; the SVD
    where either would be ill-conditioned or the sign ambiguous (the same plane, at a higher cost).
    """
    S = np.asarray(S, dtype=np.float64).reshape(-1, 3)
    if S.shape[0] < 3:
        return _Z.copy()
    if S.shape[0] == 3:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = S.tolist()
        ux, uy, uz, vx, vy, vz = bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 1e-12 * max(1.0, ux * ux + uy * uy + uz * uz, vx * vx + vy * vy + vz * vz):
            s = -1.0 / length if nz < 0 else 1.0 / length
            return np.array([nx * s, ny * s, nz * s])
    else:
        n3 = _least_squares_normal(S.tolist())
        if n3 is not None:
            return np.array(n3)
    _, _, vt = np.linalg.svd(S - _pt(S), full_matrices=False)
    n = vt[-1]
    return -n if n[2] < 0 else n


_GAP = 1e-6
"""Least gap between the two smallest eigenvalues of a surface's scatter, relative to the largest, for the
closed-form normal; below it (a line-like or blob-like point set) the SVD decides."""
_TILT = 1e-6
"""Least |z| of the closed-form normal: below it (a vertical surface) the sign is the SVD's, bit for bit."""


def _least_squares_normal(P: list[list[float]]) -> tuple[float, float, float] | None:
    """Unit normal of the least-squares plane through ``P`` (k >= 4 points), z >= 0, in closed form.

    The normal is the eigenvector of the points' 3x3 scatter matrix with the smallest eigenvalue (what
    the SVD's last right singular vector is), the eigenvalues by the trigonometric solution of the
    characteristic cubic and the vector as the longest cross product of two rows of ``C - lambda I``:
    a few microseconds of arithmetic instead of an SVD call. Returns None when the answer would be
    ill-conditioned or its sign ambiguous (see :data:`_GAP`, :data:`_TILT`): the caller then uses the SVD.
    """
    k = len(P)
    mx = sum(q[0] for q in P) / k
    my = sum(q[1] for q in P) / k
    mz = sum(q[2] for q in P) / k
    xx = xy = xz = yy = yz = zz = 0.0
    for x, y, z in P:
        x, y, z = x - mx, y - my, z - mz
        xx += x * x
        xy += x * y
        xz += x * z
        yy += y * y
        yz += y * z
        zz += z * z
    q = (xx + yy + zz) / 3.0
    off = xy * xy + xz * xz + yz * yz
    p2 = (xx - q) ** 2 + (yy - q) ** 2 + (zz - q) ** 2 + 2.0 * off
    if not p2 > 0.0:
        return None  # isotropic or degenerate (or NaN): no plane
    p = math.sqrt(p2 / 6.0)
    a, b, c, d, e, f = (xx - q) / p, xy / p, xz / p, (yy - q) / p, yz / p, (zz - q) / p  # B = (C - qI) / p
    r = (a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c)) / 2.0
    phi = math.acos(max(-1.0, min(1.0, r))) / 3.0
    big = q + 2.0 * p * math.cos(phi)
    small = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    mid = 3.0 * q - big - small
    if not (big > 0.0 and mid - small > _GAP * big):
        return None
    r0 = (xx - small, xy, xz)
    r1 = (xy, yy - small, yz)
    r2 = (xz, yz, zz - small)
    best, n = -1.0, (0.0, 0.0, 1.0)
    for u, v in ((r0, r1), (r0, r2), (r1, r2)):
        c3 = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        m = c3[0] * c3[0] + c3[1] * c3[1] + c3[2] * c3[2]
        if m > best:
            best, n = m, c3
    length = math.sqrt(best)
    if not length > 0.0:
        return None
    nx, ny, nz = n[0] / length, n[1] / length, n[2] / length
    if abs(nz) < _TILT:
        return None
    return (-nx, -ny, -nz) if nz < 0 else (nx, ny, nz)


def angle_between(u: np.ndarray, v: np.ndarray) -> float:
    """Angle in radians, in [0, pi], between two direction vectors (3,)."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    nu, nv = _norm(u), _norm(v)
    if nu < 1e-12 or nv < 1e-12:
        return 0.0
    c = float(u.dot(v)) / (nu * nv)
    return math.acos(max(-1.0, min(1.0, c)))


def angle_to_vertical(u: np.ndarray) -> float:
    """Angle in radians, in [0, pi/2], between the (unsigned) direction ``u`` and the world z axis."""
    a = angle_between(u, _Z)
    return min(a, math.pi - a)


def _polygon_xy(poly: np.ndarray) -> list[tuple[float, float]] | None:
    """The xy corners of ``poly`` (k >= 3, 3) in angular order around their centroid; None for k < 3."""
    P = np.asarray(poly, dtype=np.float64).reshape(-1, 3)[:, :2].tolist()
    k = len(P)
    if k < 3:
        return None
    cx = sum(q[0] for q in P) / k
    cy = sum(q[1] for q in P) / k
    P.sort(key=lambda q: math.atan2(q[1] - cy, q[0] - cx))
    return P


def _inside(x: float, y: float, P: list[tuple[float, float]]) -> bool:
    """Even-odd rule: does the horizontal ray from (x, y) cross the closed polygon ``P`` an odd number of times."""
    inside = False
    xj, yj = P[-1]
    for xi, yi in P:
        if (yi > y) != (yj > y) and x < xi + (y - yi) * (xj - xi) / (yj - yi):
            inside = not inside
        xj, yj = xi, yi
    return inside


def point_in_polygon(p: np.ndarray, poly: np.ndarray) -> bool:
    """True when point ``p`` lies inside polygon ``poly`` (k >= 3, 3), both projected on the xy plane.

    The polygon's corners are taken in angular order around their centroid, so a surface element's
    4 corner points work in any order.
    """
    P = _polygon_xy(poly)
    if P is None:
        return False
    x, y = _pt(p)[:2].tolist()
    return _inside(x, y, P)


def count_in_polygon(points: list[np.ndarray] | np.ndarray, poly: np.ndarray) -> int:
    """How many of ``points`` (a list of points/elements, or an (N, 3) array) lie inside ``poly`` (xy)."""
    P = _polygon_xy(poly)
    if P is None:
        return 0
    n = 0
    for q in points:
        x, y = _pt(q)[:2].tolist()
        n += _inside(x, y, P)
    return n


def signed_height(p: np.ndarray, S: np.ndarray) -> float:
    """Signed distance (metres) of point ``p`` from the plane of surface ``S``; positive on the +normal side."""
    S = np.asarray(S, dtype=np.float64).reshape(-1, 3)
    return float((_pt(p) - _pt(S)).dot(normal(S)))


def point_above_surface(p: np.ndarray, S: np.ndarray, margin: float = 0.0) -> bool:
    """True when ``p`` projects (xy) inside surface ``S`` and lies more than ``margin`` metres above its plane."""
    return point_in_polygon(p, S) and signed_height(p, S) > margin


def displacement(Hi: np.ndarray) -> float:
    """Net motion (metres) of an element's centroid over its history ``Hi`` (T, k, 3): |last - first|."""
    Hi = np.asarray(Hi, dtype=np.float64)
    if Hi.ndim != 3 or Hi.shape[0] < 2:
        return 0.0
    k = Hi.shape[1]
    if k == 0:
        return math.nan  # no points: no centroid
    d = np.add.reduce(Hi[-1] - Hi[0], 0)  # k times the centroid's motion, in one reduction
    return math.sqrt(float(d.dot(d))) / k


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
