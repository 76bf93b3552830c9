"""Where the painter's elements come from: the names of the two sources and their check.

``part-masks`` (the method): the segmenter's constraint-aware instance and part masks, lifted, fused and fitted
(:mod:`code_as_monitor.geometry.elements`). ``orb-keypoints`` (the ablation "CS off",
:mod:`code_as_monitor.painter.keypoint_elements`): classical ORB keypoints on the object's image region, lifted with
depth and clustered; our offline analogue of the paper's DINOv2 points, not DINOv2.
"""

from __future__ import annotations

from code_as_monitor.core.errors import ConfigError

PART_MASKS = "part-masks"
ORB_KEYPOINTS = "orb-keypoints"
ELEMENT_SOURCES = (PART_MASKS, ORB_KEYPOINTS)


def check_element_source(value: object, owner: str = "Painter.element_source") -> str:
    """``value`` if it names an element source; ConfigError naming it otherwise."""
    if not isinstance(value, str) or value not in ELEMENT_SOURCES:
        raise ConfigError(f"{owner} must be one of {', '.join(ELEMENT_SOURCES)}, got {value!r}")
    return value


__all__ = ["ELEMENT_SOURCES", "ORB_KEYPOINTS", "PART_MASKS", "check_element_source"]
