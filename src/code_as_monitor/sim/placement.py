"""Ground truth for a placing release: did the object come to rest where the skill was putting it?

A placing skill (the gripper's ``insert`` and ``stow``) lowers the held object into its target and opens the
fingers; it logs a ``released`` event (``obj``, ``target``, ``skill``). Whether that release succeeded is only
known once the object has come to rest: a book let go beside its shelf falls over, a book let go in the slot may
still tip over. :class:`PlacementWatch`, a tick hook installed on every simulated world, judges each release
with the task's own test (:meth:`~code_as_monitor.sim.tasks.base.Task.placed`) when the object has been still
for :data:`REST_S` (or :data:`JUDGE_MAX_S` after the release in any case) and logs, at the release's time:

- ``placed`` (``obj``, ``target``, ``reason``, ``judged_at``): it rests in place;
- ``misplaced`` (the same keys, and ``after``: the disturbance event, as ``{"t", "kind", "obj"}``, that
  concerned the object or the target during the placing action, if any): it rests out of place, a failure of
  the episode unless something is done (:mod:`code_as_monitor.bench.metrics` merges one with an ``after`` into
  that disturbance, its cause).

A release is not judged when, before the object came to rest, it was taken again (``gripper_close`` on it), a
disturbance moved it (its own event is the failure), or another placing release of it followed. The watch keeps
no state the event log does not hold except the stillness counters, which a restored world (a counterfactual
rollout's :meth:`~code_as_monitor.sim.world.World.restore_state` truncates the log) resets: a rollout's releases
vanish with its events.
"""

from __future__ import annotations

from typing import Any

import numpy as np

REST_S = 0.3
"""Seconds the released object must stay still before its placement is judged."""
JUDGE_MAX_S = 5.0
"""Seconds after the release at which it is judged whether or not it is still (``at_rest`` False then)."""
STILL_LIN = 0.01
"""Metres per second: at most this linear speed counts as still."""
STILL_ANG = 0.2
"""Radians per second: at most this angular speed counts as still (a book rocking on its edge is not)."""
DISTURBANCE_KINDS = ("object_moved", "grasp_perturbed", "object_knocked", "grasp_slipped", "drop", "pour_undone")
"""Events a disturbance logs (:mod:`~code_as_monitor.sim.triggered`, :mod:`~code_as_monitor.sim.disturbances`)."""
_JUDGED = ("placed", "misplaced")


class PlacementWatch:
    """Tick hook judging placing releases (see the module docstring); ``task`` supplies ``placed``."""

    def __init__(self, task: Any) -> None:
        self.task = task
        self._still: dict[tuple[str, float], int] = {}  # (obj, release t) -> consecutive still ticks
        self._seen = 0  # event count at the last tick (a smaller one: the world was restored)
        self._key: tuple[int, int] | None = None  # (count, id of the last event) the open releases were found for
        self._open: list[int] = []
        self._untested: set[tuple[str, float]] = set()  # releases the task has no test for

    def __call__(self, world: Any) -> None:
        events = world.events.events
        if len(events) < self._seen:
            self._still.clear()
        self._seen = len(events)
        key = (len(events), id(events[-1]) if events else 0)
        if key != self._key:  # the log changed: look for unjudged releases again (not every tick of every task)
            self._key, self._open = key, _open_releases(events)
        for i in self._open:
            if (events[i]["obj"], events[i]["t"]) not in self._untested:
                self._watch(world, events, i)

    def _watch(self, world: Any, events: list[dict[str, Any]], i: int) -> None:
        rel = events[i]
        obj, key = rel["obj"], (rel["obj"], rel["t"])
        later = events[i + 1:]
        if any(e.get("obj") == obj and (e["kind"] in DISTURBANCE_KINDS or e["kind"] in ("gripper_close", "released"))
               for e in later):
            self._still.pop(key, None)
            return
        import pybullet as pb

        lin, ang = pb.getBaseVelocity(world.body_of(obj), physicsClientId=world.client)
        still = float(np.linalg.norm(lin)) <= STILL_LIN and float(np.linalg.norm(ang)) <= STILL_ANG
        n = self._still.get(key, 0) + 1 if still else 0
        self._still[key] = n
        at_rest = n * world.dt >= REST_S - 1e-9
        if not at_rest and world.t - rel["t"] < JUDGE_MAX_S:
            return
        verdict = self.task.placed(world, obj, rel.get("target", ""))
        self._still.pop(key, None)
        if verdict is None:  # the task has no test for this object: nothing to log
            self._untested.add(key)
            return
        ok, reason = verdict
        extra: dict[str, Any] = {"target": rel.get("target", ""), "reason": reason, "judged_at": round(world.t, 3),
                                 "at_rest": at_rest}
        if not ok:
            cause = _cause(events[:i], obj, rel.get("target", ""))
            if cause is not None:
                extra["after"] = cause
        world.events.log(rel["t"], "placed" if ok else "misplaced", obj, **extra)


def _open_releases(events: list[dict[str, Any]]) -> list[int]:
    """Indices of ``released`` events without a ``placed`` / ``misplaced`` judgement (same object and time)."""
    judged = {(e["obj"], e["t"]) for e in events if e["kind"] in _JUDGED}
    return [i for i, e in enumerate(events) if e["kind"] == "released" and (e["obj"], e["t"]) not in judged]


def _cause(before: list[dict[str, Any]], obj: str, target: str) -> dict[str, Any] | None:
    """The last disturbance event about ``obj`` or ``target`` since the placing action began (the last
    ``action_start`` in ``before``), as ``{"t", "kind", "obj"}``; None if there was none."""
    for e in reversed(before):
        if e["kind"] == "action_start":
            return None
        if e["kind"] in DISTURBANCE_KINDS and e.get("obj") in (obj, target):
            return {"t": e["t"], "kind": e["kind"], "obj": e["obj"]}
    return None


__all__ = ["PlacementWatch"]
