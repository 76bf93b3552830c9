"""Bounded element history: what the monitor program reads as ``H``.

:class:`ElementHistory` keeps the last ``maxlen`` frames of every element's points in preallocated
numpy ring buffers. Each frame is written twice, at slot ``i`` and ``i + maxlen`` of a buffer of
``2 * maxlen`` rows, so the last ``T`` frames are always one contiguous slice, oldest first: reading
the history never re-stacks a list, it is one slice (copied by default).
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.errors import ConfigError, PerceptionError


class ElementHistory:
    """Ring buffer of ``{element id: (k, 3)}`` frames with timestamps.

    Args:
        maxlen: frames kept (>= 1); older frames are dropped.

    Every push must carry the same element ids with the same point counts as the first one (the
    element set of a subgoal is fixed); start a new history (or :meth:`clear`) for a new subgoal.
    """

    def __init__(self, maxlen: int = 64) -> None:
        if int(maxlen) < 1:
            raise ConfigError(f"ElementHistory.maxlen must be >= 1, got {maxlen!r}")
        self.maxlen = int(maxlen)
        self.clear()

    def clear(self) -> None:
        """Forget every frame and the element set."""
        self._bufs: dict[int, np.ndarray] = {}  # id -> (2*maxlen, k, 3)
        self._t = np.zeros(2 * self.maxlen, dtype=np.float64)
        self._next = 0  # slot the next frame goes to, in [0, maxlen)
        self._len = 0

    def __len__(self) -> int:
        return self._len

    @property
    def ids(self) -> list[int]:
        """Element ids held, in first-push order."""
        return list(self._bufs)

    def push(self, t: float, points: dict[int, np.ndarray]) -> None:
        """Append one frame.

        Args:
            t: observation time, seconds; must not decrease.
            points: element id -> (k, 3) world metres.
        Raises:
            PerceptionError: the element ids or point counts differ from the first frame's, or time
                went backwards.
        """
        if not self._bufs:
            if not points:
                raise PerceptionError("ElementHistory.push: no elements given")
            for eid, p in points.items():
                arr = np.asarray(p, dtype=np.float64)
                if arr.ndim != 2 or arr.shape[1] != 3:
                    raise PerceptionError(f"ElementHistory.push: element {eid} points must be (k, 3), got {arr.shape}")
                self._bufs[int(eid)] = np.zeros((2 * self.maxlen, arr.shape[0], 3), dtype=np.float64)
        elif points.keys() != self._bufs.keys():
            raise PerceptionError(
                f"ElementHistory.push: element ids {sorted(points)} differ from the history's {sorted(self._bufs)}; "
                "clear() the history for a new element set"
            )
        if self._len and t < self._t[self._next - 1 + self.maxlen]:
            raise PerceptionError(
                f"ElementHistory.push: time went backwards ({t} < {self._t[self._next - 1 + self.maxlen]})"
            )
        frame = {eid: np.asarray(points[eid], dtype=np.float64) for eid in self._bufs}
        for eid, p in frame.items():  # validate everything before writing anything
            if p.shape != self._bufs[eid].shape[1:]:
                raise PerceptionError(
                    f"ElementHistory.push: element {eid} has shape {p.shape}, expected {self._bufs[eid].shape[1:]}"
                )
        i, j = self._next, self._next + self.maxlen
        for eid, buf in self._bufs.items():
            buf[i] = frame[eid]
            buf[j] = frame[eid]
        self._t[i] = self._t[j] = t
        self._next = (self._next + 1) % self.maxlen
        self._len = min(self._len + 1, self.maxlen)

    def _window(self) -> slice:
        # The newest frame sits at slot next-1 (+ maxlen); the oldest `len` frames end there.
        end = self._next + self.maxlen  # exclusive, in [maxlen, 2*maxlen)
        return slice(end - self._len, end)

    def arrays(self, copy: bool = True) -> tuple[dict[int, np.ndarray], np.ndarray]:
        """The history, oldest frame first.

        Args:
            copy: False returns read-only views into the ring buffer, valid until the next push.
        Returns:
            H: element id -> (T, k, 3) world metres; t: (T,) seconds.
        """
        s = self._window()
        H: dict[int, np.ndarray] = {}
        for eid, buf in self._bufs.items():
            H[eid] = buf[s].copy() if copy else _readonly(buf[s])
        t = self._t[s].copy() if copy else _readonly(self._t[s])
        return H, t

    def latest(self) -> tuple[dict[int, np.ndarray], float]:
        """The newest frame (copies): element id -> (k, 3), and its time. Raises when empty."""
        if not self._len:
            raise PerceptionError("ElementHistory.latest: the history is empty")
        i = self._next - 1 + self.maxlen
        return {eid: buf[i].copy() for eid, buf in self._bufs.items()}, float(self._t[i])


def _readonly(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v
