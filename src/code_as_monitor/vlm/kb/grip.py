"""Constraints every parallel-jaw grasp shares (pen, book, ...): in the gripper, lifted, still gripped.

The object's element is passed in (the pen's axis line, the book's cover point, ...); thresholds come
from the knowledge base's table under the names the caller gives.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.vlm.kb.skills import _c, nice

GRIP_TIP = {"name": "gripper grasp point", "obj": "robot", "part": "tip", "kind": "point"}
"""The grasp point between the fingers, from forward kinematics (never segmented)."""


def part_spec(obj: str, part: str, kind: str, label: str) -> dict[str, str]:
    """An element spec: ``obj``'s ``part`` as a ``kind`` element, named "<obj> <label>" in the legend."""
    return {"name": f"{obj.replace('_', ' ')} {label}", "obj": obj, "part": part, "kind": kind}


def in_gripper(obj: str, part: dict[str, str], li: dict[str, float]) -> list[dict[str, Any]]:
    """Upon a grasp: the object's centre within ``li['max_dist']`` of the grasp point, and above ``li['min_z']``."""
    return [
        _c(f"grasped_{obj}", f"{nice(obj)} is in the gripper: its centre within {li['max_dist'] * 100:.0f} cm of the "
           f"grasp point", "upon", False, li, [GRIP_TIP, part]),
        _c(f"lifted_{obj}", f"{nice(obj)} is lifted: its centre above {li['min_z'] * 100:.0f} cm", "upon", False, li,
           [part]),
    ]


def still_gripped(obj: str, part: dict[str, str], gr: dict[str, float]) -> dict[str, Any]:
    """During a move: the object stays within ``gr['max_dist']`` of the grasp point."""
    return _c(f"gripped_{obj}", f"{nice(obj)} stays in the gripper (within {gr['max_dist'] * 100:.0f} cm of the grasp "
              f"point)", "during", False, gr, [GRIP_TIP, part])
