# ruff: noqa: E501  (the bodies are generated code, kept one statement per line)
"""Monitor-code templates for the ``open-drawer`` constraints.

Same rules as :mod:`code_as_monitor.vlm.kb.templates`: one decision per check (so path coverage reaches both
branches), literal ``True``/``False`` returns, reasons with every measurement, only ``np``, ``math`` and the
monitor helpers. Element order in a constraint's parts is the contract with :mod:`code_as_monitor.vlm.kb.drawer`:
``tip`` the gripper's grasp point, ``handle`` the handle bar's centre, ``drawer`` the drawer front and
``frame`` the cabinet's body, ``finger_left``/``finger_right`` the gripper's jaws (proprioception; their
distance is the jaw opening), all points (world metres).

How far the drawer came out: the drawer's axis is the horizontal direction from the frame's point to the
drawer front's point (the front sits ahead of the cabinet's body along the axis, and only the direction is
used, so a few cm of painting error in either point tilt it by a few degrees). The drawer front's travel is
measured on its handle, a compact bar fixed to the front whose painted point is the same however far the
drawer is out (the drawer's own visible area grows as its tray comes out, which moves its painted centre):
``opened`` = |(handle now - handle at the oldest frame of ``H``) . axis|, metres. ``H`` starts with the subgoal,
so this is the travel since the pull began. The sign is dropped: on its rails a drawer that starts the pull
closed or a few cm out (after a slip) can only travel ``min_open`` by coming out, and path coverage's moving
histories point in random directions, so a signed test leaves its True branch unreached for some cabinet
headings. (The projection still ignores sideways drift of the tracked point.)
"""

from __future__ import annotations

from collections.abc import Callable

from code_as_monitor.vlm.kb.templates import Spec, _f, _fn, _name, _q


def _opened(h: int, dr: int, fr: int) -> str:
    """Lines computing ``axis`` (3,) and ``opened`` (metres out along it since the oldest frame of H)."""
    return f"""
    axis = centroid(E[{dr}]) - centroid(E[{fr}])
    axis = np.array([axis[0], axis[1], 0.0]) / (np.linalg.norm(axis[:2]) + 1e-9)
    opened = np.abs(np.dot(centroid(E[{h}]) - centroid(H[{h}][0]), axis))
"""


def drawerstill(c: Spec) -> str:
    """Parts: [handle (point)]. The handle has not moved since the grasp began (it is never lifted: a grasped
    handle stays where it is too, so this needs no "unless held" escape)."""
    (h,) = c["element_ids"][:1]
    th, hn = c["thresholds"], _name(c, 0)
    mx = _f(th["max_disp"])
    body = f"""
    m = displacement(H[{h}])
    if m <= {mx}:
        return True, {_q("the handle of " + hn + " stays where it was (moved %.3f m)")} % m, {mx} - m
    return False, {_q("the handle of " + hn + " moved %.3f m while the gripper approached: the drawer moved and the jaws will close on nothing")} % m, {mx} - m
"""
    return _fn(c, body)


def handlegrip(c: Spec) -> str:
    """Parts: [tip (point), handle (point)]. The handle's centre is at the grasp point."""
    tip, h = c["element_ids"][:2]
    th, hn = c["thresholds"], _name(c, 1)
    md = _f(th["max_dist"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{h}]))
    if d <= {md}:
        return True, {_q("the handle of " + hn + " is between the fingers (%.3f m from the grasp point)")} % d, {md} - d
    return False, {_q("the handle of " + hn + " is not between the fingers: %.3f m from the grasp point (limit " + md + ")")} % d, {md} - d
"""
    return _fn(c, body)


def jawshut(c: Spec) -> str:
    """Parts: [left finger (point), right finger (point)]. The jaws are closed on something about the handle's
    width: their opening (the fingers' distance) between ``min_jaw`` and ``max_jaw``."""
    fl, fr = c["element_ids"][:2]
    th = c["thresholds"]
    lo, hi = _f(th["min_jaw"]), _f(th["max_jaw"])
    body = f"""
    jaw = distance(E[{fl}], E[{fr}])
    margin = np.min([jaw - {lo}, {hi} - jaw])
    if jaw >= {lo} and jaw <= {hi}:
        return True, "the jaws are closed on the handle (%.3f m apart)" % jaw, margin
    return False, "the jaws are not closed on the handle: %.3f m apart (open they are 0.08 m apart, closed on nothing 0; on the handle {lo} to {hi})" % jaw, margin
"""
    return _fn(c, body)


def handled(c: Spec) -> str:
    """Parts: [tip (point), handle (point), drawer front (point), frame (point)]. The handle stays at the grasp
    point while the pull goes on, unless the drawer is already out by ``min_open`` (letting go is the plan)."""
    tip, h, dr, fr = c["element_ids"][:4]
    th, hn = c["thresholds"], _name(c, 1)
    md, mo = _f(th["max_dist"]), _f(th["min_open"])
    body = _opened(h, dr, fr) + f"""
    d = distance(E[{tip}], centroid(E[{h}]))
    margin = np.max([{md} - d, opened - {mo}])
    if d <= {md} or opened >= {mo}:
        return True, {_q("the handle of " + hn + " is in the gripper or the drawer is already out (%.3f m from the grasp point, drawer out %.3f m)")} % (d, opened), margin
    return False, {_q("the grasp slipped off the handle of " + hn + ": the handle is %.3f m from the grasp point and the drawer came out only %.3f m")} % (d, opened), margin
"""
    return _fn(c, body)


def pulled(c: Spec) -> str:
    """Parts: [handle (point), drawer front (point), frame (point)]. The drawer came out ``min_open`` along its
    axis since the pull began."""
    h, dr, fr = c["element_ids"][:3]
    th, hn = c["thresholds"], _name(c, 0)
    mo = _f(th["min_open"])
    body = _opened(h, dr, fr) + f"""
    if opened >= {mo}:
        return True, {_q("the drawer of " + hn + " came out %.3f m along its axis")} % opened, opened - {mo}
    return False, {_q("the drawer of " + hn + " came out only %.3f m along its axis (needs " + mo + ")")} % opened, opened - {mo}
"""
    return _fn(c, body)


def drawerfreed(c: Spec) -> str:
    """Parts: [tip (point), handle (point)]. The gripper has let go of the handle and moved off it."""
    from code_as_monitor.vlm.kb.manip_templates import freed

    return freed(c, "the handle of " + _name(c, 1))


DRAWER_TEMPLATES: dict[str, Callable[[Spec], str]] = {
    "drawerstill": drawerstill, "handlegrip": handlegrip, "jawshut": jawshut, "handled": handled, "pulled": pulled,
    "drawerfreed": drawerfreed,
}
"""Template key (constraint id prefix) -> writer, for the ``open-drawer`` constraints."""
