# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""What every grasp shares (pen, book, teapot, drawer handle, and the suction cup's blocks): element specs,
constraint builders (in the gripper, held, still gripped) and the templates of their checks (``grasped``,
``gripped``, ``freed``, and :func:`held_since_grasp`, the one check behind every "held / lifted / picked up"
constraint: ``held_`` and ``lifted_`` ids both use it).

A grasp is judged relative to the grasp, never by absolute height: an object resting on another (a block on the
tower, a book standing in the shelf) is already high, and a hovering tip is already close to it, so "close to
the tip and above 5 cm" holds before anything is grasped. Held means it rose with the tip since the grasp began
(the oldest frame of the subgoal's history ``H``) and is at the tip now.

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
FINGER_LEFT = {"name": "gripper left finger", "obj": "robot", "part": "finger_left", "kind": "point"}
FINGER_RIGHT = {"name": "gripper right finger", "obj": "robot", "part": "finger_right", "kind": "point"}
"""The gripper's jaws at the grasp point's depth, from proprioception; their distance is the jaw opening."""


def part_spec(obj: str, part: str, kind: str, label: str) -> dict[str, str]:
    """An element spec: ``obj``'s ``part`` as a ``kind`` element, named "<obj> <label>" in the legend."""
    return {"name": f"{obj.replace('_', ' ')} {label}", "obj": obj, "part": part, "kind": kind}


def held(obj: str, part: dict[str, Any], th: dict[str, float], tip: dict[str, Any] = GRIP_TIP,
         key: str = "held", by: str = "the gripper") -> dict[str, Any]:
    """Upon a grasp or pick: ``obj`` is held (:func:`held_since_grasp`): its centre within ``th['max_dist']`` of
    ``tip`` and risen at least ``th['min_rise']`` since the grasp began. ``key`` is the id's prefix (``held`` or
    ``lifted``: one template), ``by`` names the end effector in the text."""
    return constraint(f"{key}_{obj}", f"{nice(obj)} is held by {by}: its centre within {th['max_dist'] * 100:.0f} cm "
                      f"of the tip and risen at least {th['min_rise'] * 100:.0f} cm with it since the grasp began",
                      "upon", False, th, [tip, part])


def in_gripper(obj: str, part: dict[str, str], li: dict[str, float]) -> list[dict[str, Any]]:
    """Upon a grasp: the object's centre within ``li['max_dist']`` of the grasp point (``grasped``), and held:
    risen at least ``li['min_rise']`` with the gripper since the grasp began (``lifted``)."""
    return [
        constraint(f"grasped_{obj}", f"{nice(obj)} is in the gripper: its centre within {li['max_dist'] * 100:.0f} cm "
                   f"of the grasp point", "upon", False, li, [GRIP_TIP, part]),
        held(obj, part, li, key="lifted"),
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


def held_since_grasp(c: Spec) -> str:
    """Parts: [tip (point), object part (any)]. The part's centre is within ``max_dist`` of the tip now and has
    risen at least ``min_rise`` since the oldest frame of ``H`` (the grasp's start): it rose with the tip.

    An object resting on another under a hovering tip has not risen, so it is not held; a dropped one has not
    either, or is far from the tip."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 1)
    md, mr = num(th["max_dist"]), num(th["min_rise"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    rise = centroid(E[{x}])[2] - centroid(H[{x}][0])[2]
    margin = np.min([{md} - d, rise - {mr}])
    if d <= {md} and rise >= {mr}:
        return True, {lit(xn + " held (rose %.3f m, %.3f m from the tip)")} % (rise, d), margin
    return False, {lit(xn + " not held: rose %.3f m since the grasp (needs " + mr + "), %.3f m from the tip (limit " + md + ")")} % (rise, d), margin
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


TEMPLATES: dict[str, Template] = {"grasped": grasped, "held": held_since_grasp, "lifted": held_since_grasp,
                                  "gripped": gripped, "freed": freed}
"""Template key (constraint id prefix) -> writer, for the checks every grasp shares."""
