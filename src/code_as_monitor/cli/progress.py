"""Progress for long commands: a live bar on a terminal, plain lines (N/M, ETA) anywhere else.

Piped into a file or a CI log, a live bar prints nothing useful; :class:`ProgressLines` prints
``cam bench: 12/128 episodes (9 %), 3.1 min elapsed, ETA 29.8 min`` at most once every ``every_s``
seconds (10 s by default), and always the last one.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO


def _minutes(s: float) -> str:
    return f"{s / 60:.1f} min"


class ProgressLines:
    """Rate-limited progress lines.

    Args:
        label: what is counted, e.g. ``"cam bench"``.
        unit: plural noun of the count (``"episodes"``).
        every_s: least seconds between two lines (the final line is always printed).
        stream: where to print (default stdout); ``clock``: a monotonic clock in seconds (tests).
    """

    def __init__(self, label: str, unit: str = "items", every_s: float = 10.0, stream: TextIO | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.label, self.unit, self.every_s = label, unit, every_s
        self.stream = stream
        self.clock = clock
        self.total = 0
        self.t0 = clock()
        self._last: float | None = None

    def start(self, total: int) -> None:
        self.total = total
        self.t0 = self.clock()
        self._last = None

    def line(self, done: int, note: str = "") -> str:
        """The progress line for ``done`` of ``total`` finished."""
        elapsed = self.clock() - self.t0
        pct = 100.0 * done / self.total if self.total else 100.0
        out = f"{self.label}: {done}/{self.total} {self.unit} ({pct:.0f} %), {_minutes(elapsed)} elapsed"
        if 0 < done < self.total:
            out += f", ETA {_minutes(elapsed / done * (self.total - done))}"
        return out + (f"; last: {note}" if note else "")

    def update(self, done: int, note: str = "") -> bool:
        """Print the line if ``every_s`` passed since the last one or this is the last item; True if printed."""
        now = self.clock()
        if done < self.total and self._last is not None and now - self._last < self.every_s:
            return False
        if done < self.total and self._last is None and now - self.t0 < self.every_s:
            return False
        self._last = now
        stream = self.stream or sys.stdout
        print(self.line(done, note), file=stream, flush=True)
        return True


def is_terminal(stream: TextIO | None = None) -> bool:
    """True when ``stream`` (default stdout) is an interactive terminal."""
    s = stream or sys.stdout
    try:
        return bool(s.isatty())
    except (AttributeError, ValueError):
        return False


__all__ = ["ProgressLines", "is_terminal"]
