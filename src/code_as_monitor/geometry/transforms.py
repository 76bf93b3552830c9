"""Rigid transforms as 4x4 homogeneous matrices (metres, radians).

Convention: ``T_a_b`` maps points expressed in frame ``b`` to frame ``a``: ``p_a = T_a_b @ [p_b, 1]``.
So ``compose(T_a_b, T_b_c) == T_a_c`` and ``invert(T_a_b) == T_b_a``.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.camera import validate_rigid
from code_as_monitor.core.errors import GeometryError


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The cross product of 3-vectors ``a`` and ``b`` ((3,) or (N, 3), broadcast on the last axis): the same
    floating-point operations as :func:`numpy.cross`, so the same values, without its axis bookkeeping (ten times
    cheaper on a single pair, which the box fits do hundreds of times per subgoal)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    if np.ndim(a) == 1 and np.ndim(b) == 1:
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def make_transform(R: np.ndarray | None = None, t: np.ndarray | None = None) -> np.ndarray:
    """The (4, 4) transform with rotation ``R`` (3, 3) (identity if None) and translation ``t`` (3,)."""
    T = np.eye(4)
    if R is not None:
        R = np.asarray(R, dtype=np.float64)
        if R.shape != (3, 3):
            raise GeometryError(f"rotation must be 3x3, got shape {R.shape}")
        T[:3, :3] = R
    if t is not None:
        t = np.asarray(t, dtype=np.float64).reshape(-1)
        if t.shape != (3,):
            raise GeometryError(f"translation must have 3 entries, got shape {t.shape}")
        T[:3, 3] = t
    return validate_rigid(T, "transform")


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation of ``angle`` radians about ``axis`` (3,), right-handed (Rodrigues)."""
    a = np.asarray(axis, dtype=np.float64).reshape(3)
    n = np.linalg.norm(a)
    if n < 1e-12:
        raise GeometryError("rotation axis has zero length")
    x, y, z = a / n
    Kx = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * Kx + (1.0 - np.cos(angle)) * (Kx @ Kx)


def rotation_onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, 3) the least rotation taking direction ``a`` (3,) onto direction ``b`` (3,) (any lengths); opposite
    directions get half a turn about an axis across ``a``; a zero-length direction gives the identity."""
    a = np.asarray(a, dtype=np.float64).reshape(3)
    b = np.asarray(b, dtype=np.float64).reshape(3)
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na < 1e-9 or nb < 1e-9:
        return np.eye(3)
    a, b = a / na, b / nb
    v, c = np.cross(a, b), float(np.dot(a, b))
    if float(np.linalg.norm(v)) < 1e-9:
        if c > 0:
            return np.eye(3)
        p = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        p /= np.linalg.norm(p)
        return 2.0 * np.outer(p, p) - np.eye(3)
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def kabsch(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares rigid transform with ``dst ≈ src @ R.T + t`` (Kabsch: SVD of the cross-covariance, reflection
    removed).

    Args:
        src, dst: (n, 3) corresponding points, n >= 3 not on one line for a unique rotation.
    Returns:
        R (3, 3) proper rotation, t (3,), RMS residual (metres).
    """
    cs, cd = src.mean(axis=0), dst.mean(axis=0)
    U, _, Vt = np.linalg.svd((src - cs).T @ (dst - cd))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    t = cd - cs @ R.T
    rms = float(np.sqrt(((src @ R.T + t - dst) ** 2).sum(axis=1).mean()))
    return R, t, rms


def compose(*transforms: np.ndarray) -> np.ndarray:
    """Product ``T_1 @ T_2 @ ... @ T_n`` of (4, 4) rigid transforms (identity when none given)."""
    out = np.eye(4)
    for i, T in enumerate(transforms):
        out = out @ validate_rigid(T, f"transform #{i}")
    return out


def invert(T: np.ndarray) -> np.ndarray:
    """Inverse (4, 4) of a rigid transform, computed as ``[R^T, -R^T t]`` (exact for rigid input)."""
    T = validate_rigid(T, "transform")
    R = T[:3, :3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ T[:3, 3]
    return out


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply the (4, 4) transform ``T`` to ``points`` (N, 3) or (3,); returns the same shape, float64."""
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4):
        raise GeometryError(f"transform must be 4x4, got shape {T.shape}")
    P = np.asarray(points, dtype=np.float64)
    if P.shape[-1:] != (3,) or P.ndim not in (1, 2):
        raise GeometryError(f"points must be (N, 3) or (3,), got shape {P.shape}")
    return P @ T[:3, :3].T + T[:3, 3]
