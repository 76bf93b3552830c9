# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""What every parallel-jaw grasp shares (pen, book, teapot, drawer handle): element specs, constraint builders
(in the gripper, lifted, still gripped) and the templates of their checks (``grasped``, ``lifted``, ``gripped``,
``freed``).

The object's element is passed in (the pen's axis line, the book's cover point, ...); thresholds come from the
calling family's table. Element order in a constraint's parts is the contract between the builders and the
templates: ``[gripper tip (point), object part (any)]``.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.vlm.kb.shared.answer import constraint, nice
from code_as_monitor.vlm.kb.shared.codegen import Spec, Template, check_fn, lit, num, obj_name

GRIP_TIP = {"name": "gripper grasp point", "obj": "robot", "part": "tip", "kind": "point"}
"""The grasp point between the fingers, from forward kinematics (never segmented)."""


def part_spec(obj: str, part: str, kind: str, label: str) -> dict[str, str]:
    """An element spec: ``obj``'s ``part`` as a ``kind`` element, named "<obj> <label>" in the legend."""
    return {"name": f"{obj.replace('_', ' ')} {label}", "obj": obj, "part": part, "kind": kind}


def in_gripper(obj: str, part: dict[str, str], li: dict[str, float]) -> list[dict[str, Any]]:
    """Upon a grasp: the object's centre within ``li['max_dist']`` of the grasp point, and above ``li['min_z']``."""
    return [
        constraint(f"grasped_{obj}", f"{nice(obj)} is in the gripper: its centre within {li['max_dist'] * 100:.0f} cm "
                   f"of the grasp point", "upon", False, li, [GRIP_TIP, part]),
        constraint(f"lifted_{obj}", f"{nice(obj)} is lifted: its centre above {li['min_z'] * 100:.0f} cm", "upon",
                   False, li, [part]),
    ]


def still_gripped(obj: str, part: dict[str, str], gr: dict[str, float]) -> dict[str, Any]:
    """During a move: the object stays within ``gr['max_dist']`` of the grasp point."""
    return constraint(f"gripped_{obj}", f"{nice(obj)} stays in the gripper (within {gr['max_dist'] * 100:.0f} cm of "
                      f"the grasp point)", "during", False, gr, [GRIP_TIP, part])


# --- templates ------------------------------------------------------------------------------------------------
def _at_grasp_point(c: Spec, failure: str) -> str:
    """Parts: [gripper tip (point), object part (any)]: the part's centre is at the grasp point.

    ``failure`` is the reason text when it is not, with ``%.3f`` for the distance."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 1)
    md = num(th["max_dist"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    if d <= {md}:
        return True, {lit(xn + " is in the gripper (%.3f m from the grasp point)")} % d, {md} - d
    return False, {lit(xn + failure.replace("{md}", md))} % d, {md} - d
"""
    return check_fn(c, body)


def grasped(c: Spec) -> str:
    """Upon a grasp: the object part is at the grasp point."""
    return _at_grasp_point(c, " is not held in the gripper: %.3f m from the grasp point (limit {md})")


def lifted(c: Spec) -> str:
    """Parts: [object part (any)]. The part is off the table (a separate decision from ``grasped``)."""
    (x,) = c["element_ids"][:1]
    th, xn = c["thresholds"], obj_name(c, 0)
    mz = num(th["min_z"])
    body = f"""
    z = centroid(E[{x}])[2]
    if z >= {mz}:
        return True, {lit(xn + " is lifted to %.3f m")} % z, z - {mz}
    return False, {lit(xn + " is not lifted: its centre is %.3f m above the table (needs " + mz + "), not held")} % z, z - {mz}
"""
    return check_fn(c, body)


def gripped(c: Spec) -> str:
    """During a move: the held part stays at the grasp point (else it was dropped)."""
    return _at_grasp_point(c, " dropped: it is %.3f m from the grasp point, no longer held")


def freed(c: Spec, label: str = "") -> str:
    """Parts: [gripper tip (point), object part (any)]. The gripper has let go and moved away. ``label``
    names what was held in the reasons (default: the object's name)."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], label or obj_name(c, 1)
    rd = num(th["release_dist"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    if d >= {rd}:
        return True, {lit(xn + " is released (the grasp point is %.3f m away)")} % d, d - {rd}
    return False, {lit(xn + " is still held: the grasp point is %.3f m from it")} % d, d - {rd}
"""
    return check_fn(c, body)


TEMPLATES: dict[str, Template] = {"grasped": grasped, "lifted": lifted, "gripped": gripped, "freed": freed}
"""Template key (constraint id prefix) -> writer, for the checks every grasp shares."""
