"""One frame on the wire between the control process and a sandbox worker: one float64 buffer plus its layout.

:func:`pack` (control process) flattens the elements, their histories and the history timestamps into a
single ``bytes`` object (cheaper than pickling many arrays); :func:`unpack` (worker) rebuilds them as
read-only views of that buffer, so a program cannot write into its inputs and nothing it does reaches the
arrays the control process holds.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.errors import ShapeMismatchError


def pack(elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
         history_t: np.ndarray | None, t: float) -> tuple[tuple, tuple, bytes]:
    """Flatten a frame into one float64 buffer plus its layout.

    Args:
        elements: element id -> (k, 3) points (a single (3,) point is accepted), world metres.
        history: element id -> (T, k, 3), oldest first; None means the current frame alone.
        history_t: (T,) seconds of the history frames (None with ``history=None``).
        t: current time, seconds.
    Returns:
        ``((id, k), ...)`` of the elements, ``((id, T, k), ...)`` of the history, and the bytes of
        ``[E..., H..., H.t]``. ``history=None`` means the current frame alone (T = 1, ``H.t = [t]``).
    Raises:
        ShapeMismatchError: points are not (k, 3), histories not (T, k, 3), or ``history_t`` not (T,).
    """
    E = [(int(i), np.asarray(p, dtype=np.float64)) for i, p in elements.items()]
    for i, p in E:
        if (p.ndim != 2 or p.shape[1] != 3) and p.shape != (3,):
            raise ShapeMismatchError(f"element {i}: points must be (k, 3), got {p.shape}")
    E = [(i, p.reshape(-1, 3)) for i, p in E]
    if history is None:
        Hs = [(i, p[None]) for i, p in E]
        Ht = np.array([t], dtype=np.float64)
    else:
        Hs = [(int(i), np.asarray(h, dtype=np.float64)) for i, h in history.items()]
        Ht = np.asarray(history_t if history_t is not None else [t], dtype=np.float64).reshape(-1)
        for i, h in Hs:
            if h.ndim != 3 or h.shape[2] != 3 or h.shape[0] != Ht.shape[0]:
                raise ShapeMismatchError(f"history of element {i} must be (T={Ht.shape[0]}, k, 3), got {h.shape}")
    parts = [p.ravel() for _, p in E] + [h.ravel() for _, h in Hs] + [Ht]
    data = np.concatenate(parts).tobytes() if parts else b""
    return tuple((i, p.shape[0]) for i, p in E), tuple((i, h.shape[0], h.shape[1]) for i, h in Hs), data


def unpack(layout_e: tuple, layout_h: tuple, data: bytes) -> tuple[dict, dict, np.ndarray]:
    """Rebuild E (id -> (k, 3)), H (id -> (T, k, 3)) and H.t (T,) as read-only views of ``data``."""
    flat = np.frombuffer(data, dtype=np.float64)  # bytes are immutable: every view is read-only
    E: dict[int, np.ndarray] = {}
    o = 0
    for i, k in layout_e:
        E[i] = flat[o:o + 3 * k].reshape(k, 3)
        o += 3 * k
    Hd: dict[int, np.ndarray] = {}
    T = 0
    for i, T, k in layout_h:
        Hd[i] = flat[o:o + 3 * T * k].reshape(T, k, 3)
        o += 3 * T * k
    return E, Hd, flat[o:o + T]
