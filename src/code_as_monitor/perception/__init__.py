"""Perception: segmenters (masks for the painter), trackers (element motion) and the element history.

Importing this package imports only interfaces and configs; a backend's implementation (OpenCV LK,
HTTP client, ...) is imported when :func:`make_segmenter` / :func:`make_tracker` builds it. This
package never imports the simulator.
"""

from code_as_monitor.perception.history import ElementHistory
from code_as_monitor.perception.segmenters import SegmenterConfig, SegmentResult, make_segmenter
from code_as_monitor.perception.trackers import TrackerConfig, TrackResult, make_tracker

__all__ = [
    "ElementHistory",
    "SegmentResult",
    "SegmenterConfig",
    "TrackResult",
    "TrackerConfig",
    "make_segmenter",
    "make_tracker",
]
