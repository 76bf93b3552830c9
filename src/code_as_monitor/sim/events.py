"""Ground-truth event log of a simulated episode.

Every event is a JSON-serialisable dict with at least ``t`` (sim seconds), ``kind`` (str) and
``obj`` (object name, or ``""`` when no object is involved); extra keys are kind-specific.

Kinds written by the simulator:

- disturbances (causes): ``drop`` (the suction released a held block; ``decision`` = index of the
  drop decision), ``placement_noise`` (``offset`` = [dx, dy] metres added to a place target).
- consequences: ``block_fell`` (a dropped block came to rest away from the suction, ``pos``),
  ``tower_collapsed`` (a block resting on another fell off, ``pos``), ``zone_count`` (the number of
  blocks inside the sweep zone changed, ``count``), ``opening_enclosed`` / ``opening_open`` (the
  rope's coverage of the square's opening crossed the success threshold, ``coverage``).
- the policy's own mistakes (the RLBench-style tasks' noisy policy, :mod:`code_as_monitor.sim.tasks.rlbench_base`):
  ``policy_failure`` (``what``: ``grasp_missed``, ``wrong_target``, ``pull_short``, ``item_misplaced``,
  ``screw_short``, ``turn_short``, ``cube_off_target``, ``dirt_left``; ``skill``), the episode's first failed skill;
  ``over_swept`` (sweep-half: the zone first holds more blocks than the success band accepts; ``count``,
  ``band`` = [min, max], ``objects`` = the zone and the blocks inside), once per episode.
- placing: ``released`` (a placing skill let ``obj`` go into ``target``), judged once it rests
  (:mod:`code_as_monitor.sim.placement`) as ``placed`` or ``misplaced`` (at the release's time; ``reason``,
  ``judged_at``, ``at_rest``, and for a misplacement ``after``: the disturbance during that action, if any).
- robot: ``suction_on`` / ``suction_off`` (``obj`` = the attached/released object, ``""`` if none),
  ``action_start`` / ``action_done`` / ``action_halted`` (``skill``, ``args``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import IO, Any

import numpy as np


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    return v


class EventLog:
    """An append-only list of events, optionally mirrored to a JSONL file (flushed per event)."""

    def __init__(self, path: str | Path | None = None) -> None:
        self.events: list[dict[str, Any]] = []
        self._fh: IO[str] | None = None
        if path is not None:
            self.open(path)

    def open(self, path: str | Path) -> None:
        """Mirror events (past and future) to ``path`` as JSONL; the file must not exist yet."""
        path = Path(path)
        self._fh = path.open("x", encoding="utf-8")
        for e in self.events:
            self._write(e)

    def log(self, t: float, kind: str, obj: str = "", **extra: Any) -> dict[str, Any]:
        """Record one event at sim time ``t`` seconds; returns the stored dict."""
        e = {"t": round(float(t), 6), "kind": kind, "obj": obj, **_jsonable(extra)}
        self.events.append(e)
        if self._fh is not None:
            self._write(e)
        return e

    def _write(self, e: dict[str, Any]) -> None:
        assert self._fh is not None
        self._fh.write(json.dumps(e) + "\n")
        self._fh.flush()

    def of_kind(self, *kinds: str) -> list[dict[str, Any]]:
        return [e for e in self.events if e["kind"] in kinds]

    def truncate(self, n: int) -> None:
        """Drop events after the first ``n`` (used when a saved world state is restored)."""
        del self.events[n:]

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __len__(self) -> int:
        return len(self.events)

    def __iter__(self):
        return iter(self.events)
