"""Oracle tracker: elements move rigidly with their owner's ground-truth pose.

Reads ``Observation.object_poses`` (filled only by a simulator): at reset each element's points are
expressed in its owner's frame (the ``"obj/part"`` pose when present, else the ``"obj"`` pose); each
step maps them back with the current pose. End-effector elements follow forward kinematics (see
:class:`~code_as_monitor.perception.trackers.anchor.KinematicAnchor`). Nothing is ever stale.
"""

from __future__ import annotations

import math

import numpy as np

from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import PerceptionError
from code_as_monitor.core.observation import Observation
from code_as_monitor.perception.trackers.anchor import KinematicAnchor, views_containing
from code_as_monitor.perception.trackers.base import SimTrackerConfig, Tracker, TrackResult


def _poses(obs: Observation) -> dict[str, np.ndarray]:
    if obs.object_poses is None:
        raise PerceptionError(
            "the sim tracker needs ground-truth object poses (Observation.object_poses is None, as on a "
            "real robot); use the lk tracker"
        )
    return obs.object_poses


class SimTracker(Tracker):
    """Exact element motion from ground-truth poses."""

    def __init__(self, config: SimTrackerConfig | None = None) -> None:
        super().__init__()
        self.config = config or SimTrackerConfig()
        self._local: dict[int, tuple[str, np.ndarray]] = {}  # id -> (pose key, (k, 3) owner-frame points)
        self._anchors: dict[int, KinematicAnchor] = {}
        self._order: list[int] = []

    def reset(self, obs: Observation, elements: list[Element]) -> None:
        self._local.clear()
        self._anchors.clear()
        self._order = [el.id for el in elements]
        poses: dict[str, np.ndarray] | None = None
        for el in elements:
            obj, part = el.owner
            if obj in self.config.kinematic_owners:
                self._anchors[el.id] = KinematicAnchor(obs, el)
                continue
            poses = _poses(obs) if poses is None else poses
            key = f"{obj}/{part}" if part and f"{obj}/{part}" in poses else obj
            if key not in poses:
                raise PerceptionError(
                    f"element {el.id} ({el.name!r}): no ground-truth pose for owner {obj!r}; "
                    f"poses are known for: {', '.join(sorted(poses)) or '(none)'}"
                )
            T = np.asarray(poses[key], dtype=np.float64)
            self._local[el.id] = (key, (el.points - T[:3, 3]) @ T[:3, :3])

    def step(self, obs: Observation) -> TrackResult:
        found: dict[int, np.ndarray] = {}
        if self._local:
            poses = _poses(obs)
            for eid, (key, local) in self._local.items():
                if key not in poses:
                    raise PerceptionError(f"ground-truth pose of {key!r} disappeared from the observation")
                T = np.asarray(poses[key], dtype=np.float64)
                found[eid] = local @ T[:3, :3].T + T[:3, 3]
        for eid, anchor in self._anchors.items():
            found[eid] = anchor.points(obs)
        points = {eid: found[eid] for eid in self._order}  # the order elements were given in
        stale = {eid: np.zeros(len(p), dtype=bool) for eid, p in points.items()}
        visible = {eid: views_containing(obs, p) for eid, p in points.items()}
        return TrackResult(obs.t, points, stale, visible, {eid: math.inf for eid in points})  # exact motion
