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
    asarray, f64 = np.asarray, np.float64
    layout_e: list[tuple[int, int]] = []
    parts: list[bytes] = []  # joined as bytes: cheaper than concatenating arrays for a few small ones
    for i, p in elements.items():
        p = asarray(p, dtype=f64)
        s = p.shape
        if len(s) == 2 and s[1] == 3:
            k = s[0]
        elif s == (3,):
            k = 1
        else:
            raise ShapeMismatchError(f"element {i}: points must be (k, 3), got {s}")
        layout_e.append((int(i), k))
        parts.append(p.tobytes())
    if history is None:
        layout_h = [(i, 1, k) for i, k in layout_e]
        parts += parts[:]  # each element's history is its current points
        parts.append(np.array([t], dtype=f64).tobytes())
    else:
        Ht = asarray(history_t if history_t is not None else [t], dtype=f64).reshape(-1)
        T = Ht.shape[0]
        layout_h = []
        for i, h in history.items():
            h = asarray(h, dtype=f64)
            s = h.shape
            if len(s) != 3 or s[2] != 3 or s[0] != T:
                raise ShapeMismatchError(f"history of element {i} must be (T={T}, k, 3), got {s}")
            layout_h.append((int(i), T, s[1]))
            parts.append(h.tobytes())
        parts.append(Ht.tobytes())
    return tuple(layout_e), tuple(layout_h), b"".join(parts)


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
