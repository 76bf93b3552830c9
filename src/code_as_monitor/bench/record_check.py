"""Value checks of the episode records a report reads (a results file is input: it may be edited, merged
from elsewhere or written by other code).

:func:`check_episode_record` raises :class:`~code_as_monitor.core.errors.RunError` naming the file, the
record and the field for a value of the wrong type or out of range: a string or null ``success``, a NaN or
negative ``sim_time_s``, a ``vlm`` that is not an object of counts, alarms or ground-truth events that are
not objects with a finite time ``t`` (and, for events, a ``kind``), a negative seed or episode.
"""

from __future__ import annotations

import math
import numbers
from pathlib import Path
from typing import Any

from code_as_monitor.core.errors import RunError


def _finite(x: Any) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)


def _problem(r: dict[str, Any]) -> str | None:
    for key in ("condition", "method"):
        if not isinstance(r.get(key), str) or not r[key]:
            return f"{key} must be a non-empty string, got {r.get(key)!r}"
    for key in ("seed", "episode"):
        if not isinstance(r.get(key), int) or isinstance(r[key], bool) or r[key] < 0:
            return f"{key} must be an integer >= 0, got {r.get(key)!r}"
    if not isinstance(r.get("success"), bool):
        return f"success must be true or false, got {r.get('success')!r}"
    errored = isinstance(r.get("error"), str) and r["error"] and r.get("sim_time_s") is None  # no time to report
    if not errored and (not _finite(r.get("sim_time_s")) or r["sim_time_s"] < 0):
        return f"sim_time_s must be a finite number >= 0, got {r.get('sim_time_s')!r}"
    vlm = r.get("vlm")
    if not isinstance(vlm, dict):
        return f"vlm must be an object of counts, got {vlm!r}"
    for key in ("calls", "total_tokens"):
        if not _finite(vlm.get(key)) or vlm[key] < 0:
            return f"vlm.{key} must be a finite number >= 0, got {vlm.get(key)!r}"
    for key in ("alarms", "gt"):
        items = r.get(key)
        if not isinstance(items, list):
            return f"{key} must be a list, got {items!r}"
        for j, e in enumerate(items):
            if not isinstance(e, dict) or not _finite(e.get("t")):
                return f"{key}[{j}] must be an object with a finite time t, got {e!r}"[:200]
            if key == "gt" and not isinstance(e.get("kind"), str):
                return f"gt[{j}] has no event kind: {e!r}"[:200]
            if key == "alarms" and e.get("cf") is not None and not isinstance(e["cf"], dict):
                return f"alarms[{j}].cf must be an object or null, got {e['cf']!r}"[:200]
    return None


def check_episode_record(path: str | Path, index: int, r: dict[str, Any]) -> None:
    """Raise RunError naming ``path``, the record's number (``index`` counts from 1) and the bad field."""
    why = _problem(r)
    if why is not None:
        raise RunError(f"results {path}: episode record {index}: {why}")


__all__ = ["check_episode_record"]
