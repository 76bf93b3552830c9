"""A small TF buffer: static and time-stamped transforms, looked up between any two connected frames.

``lookup(target, source, t_ns)`` gives ``T_target_source`` (4x4: a point in ``source`` -> ``target``)
at time ``t_ns``: static edges as they are, dynamic edges from the latest sample at or before
``t_ns`` (the earliest one when there is none before).
"""

from __future__ import annotations

import bisect

import numpy as np

from code_as_monitor.core.errors import RecordingError


class TFBuffer:
    """Transforms keyed by child frame (each child has one parent, as in TF)."""

    def __init__(self) -> None:
        self._static: dict[str, tuple[str, np.ndarray]] = {}
        self._dynamic: dict[str, tuple[str, list[int], list[np.ndarray]]] = {}

    @staticmethod
    def _norm(frame: str) -> str:
        return frame.lstrip("/")

    def add(self, parent: str, child: str, T: np.ndarray, t_ns: int, static: bool) -> None:
        parent, child = self._norm(parent), self._norm(child)
        if static:
            self._static[child] = (parent, np.asarray(T, dtype=np.float64))
            return
        _, ts, mats = self._dynamic.setdefault(child, (parent, [], []))
        i = bisect.bisect_right(ts, t_ns)
        ts.insert(i, t_ns)
        mats.insert(i, np.asarray(T, dtype=np.float64))

    @property
    def frames(self) -> set[str]:
        out = set(self._static) | set(self._dynamic)
        out |= {p for p, _ in self._static.values()} | {p for p, _, _ in self._dynamic.values()}
        return out

    def has(self, frame: str) -> bool:
        return self._norm(frame) in self.frames

    def _edge(self, child: str, t_ns: int) -> tuple[str, np.ndarray] | None:
        if child in self._static:
            return self._static[child]
        if child in self._dynamic:
            parent, ts, mats = self._dynamic[child]
            i = max(0, bisect.bisect_right(ts, t_ns) - 1)
            return parent, mats[i]
        return None

    def _to_root(self, frame: str, t_ns: int) -> tuple[str, np.ndarray]:
        """(root frame, T_root_frame)."""
        T = np.eye(4)
        seen = {frame}
        while (edge := self._edge(frame, t_ns)) is not None:
            parent, T_pc = edge
            T = T_pc @ T
            frame = parent
            if frame in seen:
                raise RecordingError(f"TF has a cycle through frame {frame!r}")
            seen.add(frame)
        return frame, T

    def lookup(self, target: str, source: str, t_ns: int) -> np.ndarray:
        """``T_target_source`` at ``t_ns``; RecordingError naming both frames when they are not connected."""
        target, source = self._norm(target), self._norm(source)
        if target == source:
            return np.eye(4)
        r1, T_r_src = self._to_root(source, t_ns)
        r2, T_r_tgt = self._to_root(target, t_ns)
        if r1 != r2:
            known = ", ".join(sorted(self.frames)) or "none"
            raise RecordingError(f"no TF path from frame {source!r} to {target!r} (TF frames in the bag: {known})")
        return np.linalg.inv(T_r_tgt) @ T_r_src


__all__ = ["TFBuffer"]
