"""Trackers: the stage registry, streaming interface and factory. Backends (``lk``, ``depth``, ``sim``) are
imported only by :func:`make_tracker`."""

from code_as_monitor.perception.trackers.base import (
    DepthTrackerConfig,
    LKTrackerConfig,
    SimTrackerConfig,
    Tracker,
    TrackerConfig,
    TrackResult,
    make_tracker,
)

__all__ = [
    "DepthTrackerConfig",
    "LKTrackerConfig",
    "SimTrackerConfig",
    "TrackResult",
    "Tracker",
    "TrackerConfig",
    "make_tracker",
]
