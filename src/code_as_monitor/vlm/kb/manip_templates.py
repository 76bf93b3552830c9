# ruff: noqa: E501  (the bodies are generated code, kept one statement per line)
"""Monitor-code templates for the gripper skills (grasp, reorient, insert): lines, surfaces, points.

Same rules as :mod:`code_as_monitor.vlm.kb.templates`: one decision per check (so path coverage
reaches both branches), literal ``True``/``False`` returns, reasons with every measurement, only
``np``, ``math`` and the monitor helpers. Element order in a constraint's parts is the contract
between :mod:`code_as_monitor.vlm.kb.manip` (which builds the parts) and these templates.
"""

from __future__ import annotations

from collections.abc import Callable

from code_as_monitor.vlm.kb.templates import Spec, _f, _fn, _name, _q


def steady(c: Spec) -> str:
    """Parts: [gripper tip (point), object part (any)]. Holds while the part has not moved or is at the tip."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], _name(c, 1)
    md, mx = _f(th["max_dist"]), _f(th["max_disp"])
    body = f"""
    m = displacement(H[{x}])
    d = distance(E[{tip}], centroid(E[{x}]))
    margin = np.max([{mx} - m, {md} - d])
    if m <= {mx} or d <= {md}:
        return True, {_q(xn + " stays in place or is in the gripper (moved %.3f m, %.3f m from the grasp point)")} % (m, d), margin
    return False, {_q(xn + " moved %.3f m while the gripper approached and is %.3f m from the grasp point: the fingers will close on nothing")} % (m, d), margin
"""
    return _fn(c, body)


def _at_grasp_point(c: Spec, failure: str) -> str:
    """Parts: [gripper tip (point), object part (any)]: the part's centre is at the grasp point.

    ``failure`` is the reason text when it is not, with ``%.3f`` for the distance."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], _name(c, 1)
    md = _f(th["max_dist"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    if d <= {md}:
        return True, {_q(xn + " is in the gripper (%.3f m from the grasp point)")} % d, {md} - d
    return False, {_q(xn + failure.replace("{md}", md))} % d, {md} - d
"""
    return _fn(c, body)


def grasped(c: Spec) -> str:
    """Upon a grasp: the object part is at the grasp point."""
    return _at_grasp_point(c, " is not held in the gripper: %.3f m from the grasp point (limit {md})")


def lifted(c: Spec) -> str:
    """Parts: [object part (any)]. The part is off the table (a separate decision from ``grasped``)."""
    (x,) = c["element_ids"][:1]
    th, xn = c["thresholds"], _name(c, 0)
    mz = _f(th["min_z"])
    body = f"""
    z = centroid(E[{x}])[2]
    if z >= {mz}:
        return True, {_q(xn + " is lifted to %.3f m")} % z, z - {mz}
    return False, {_q(xn + " is not lifted: its centre is %.3f m above the table (needs " + mz + "), not held")} % z, z - {mz}
"""
    return _fn(c, body)


def gripped(c: Spec) -> str:
    """During a move: the held part stays at the grasp point (else it was dropped)."""
    return _at_grasp_point(c, " dropped: it is %.3f m from the grasp point, no longer held")


def carried(c: Spec) -> str:
    """Parts: [gripper tip (point), object part (any), object end (point), opening (surface)]. The object
    stays at the grasp point unless its end is already inside the opening (it was let go there)."""
    tip, x, end, rim = c["element_ids"][:4]
    th, xn, rn = c["thresholds"], _name(c, 1), _name(c, 3)
    md, mo, dp = _f(th["max_dist"]), _f(th["max_offset"]), _f(th["min_depth"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    depth = centroid(E[{rim}])[2] - centroid(E[{end}])[2]
    off = horizontal_distance(E[{end}], centroid(E[{rim}]))
    margin = np.max([{md} - d, np.min([{mo} - off, depth - {dp}])])
    if d <= {md} or (off <= {mo} and depth >= {dp}):
        return True, {_q(xn + " is in the gripper or already inside " + rn + " (%.3f m from the grasp point)")} % d, margin
    return False, {_q(xn + " dropped: it is %.3f m from the grasp point and not inside " + rn)} % d, margin
"""
    return _fn(c, body)


def over(c: Spec) -> str:
    """Parts: [object end (point), opening (surface)]. Low above the rim means centred over the opening."""
    end, rim = c["element_ids"][:2]
    th, en, rn = c["thresholds"], _name(c, 0), _name(c, 1)
    ap, mo = _f(th["approach"]), _f(th["max_offset"])
    body = f"""
    h = centroid(E[{end}])[2] - centroid(E[{rim}])[2]
    off = horizontal_distance(E[{end}], centroid(E[{rim}]))
    margin = np.max([h - {ap}, {mo} - off])
    if h >= {ap} or off <= {mo}:
        return True, {_q(en + " tip is above the opening of " + rn + " or still high (offset %.3f m, %.3f m above the rim)")} % (off, h), margin
    return False, {_q(en + " tip is %.3f m above the rim but offset %.3f m from the opening of " + rn + ": not above the opening, it will miss it")} % (h, off), margin
"""
    return _fn(c, body)


def inside(c: Spec) -> str:
    """Parts: [object end (point), opening (surface)]. The end is inside the opening, below the rim."""
    end, rim = c["element_ids"][:2]
    th, en, rn = c["thresholds"], _name(c, 0), _name(c, 1)
    mo, dp = _f(th["max_offset"]), _f(th["min_depth"])
    body = f"""
    depth = centroid(E[{rim}])[2] - centroid(E[{end}])[2]
    off = horizontal_distance(E[{end}], centroid(E[{rim}]))
    margin = np.min([{mo} - off, depth - {dp}])
    if off <= {mo} and depth >= {dp}:
        return True, {_q(en + " is inside " + rn + " (%.3f m below the rim, offset %.3f m)")} % (depth, off), margin
    return False, {_q(en + " is not inside " + rn + ": %.3f m below the rim (needs " + dp + "), offset %.3f m from the opening's centre")} % (depth, off), margin
"""
    return _fn(c, body)


def freed(c: Spec, label: str = "") -> str:
    """Parts: [gripper tip (point), object part (any)]. The gripper has let go and moved away. ``label``
    names what was held in the reasons (default: the object's name)."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], label or _name(c, 1)
    rd = _f(th["release_dist"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    if d >= {rd}:
        return True, {_q(xn + " is released (the grasp point is %.3f m away)")} % d, d - {rd}
    return False, {_q(xn + " is still held: the grasp point is %.3f m from it")} % d, d - {rd}
"""
    return _fn(c, body)


MANIP_TEMPLATES: dict[str, Callable[[Spec], str]] = {
    "steady": steady, "grasped": grasped, "lifted": lifted, "gripped": gripped, "carried": carried, "over": over, "inside": inside, "freed": freed,
}
"""Template key (constraint id prefix) -> writer, for the gripper skills."""


def _register_more() -> None:
    """Add the templates of the other gripper tasks (book, ...), kept in their own modules."""
    from code_as_monitor.vlm.kb.book_templates import BOOK_TEMPLATES
    from code_as_monitor.vlm.kb.drawer_templates import DRAWER_TEMPLATES
    from code_as_monitor.vlm.kb.tea_templates import TEA_TEMPLATES

    for more in (BOOK_TEMPLATES, TEA_TEMPLATES, DRAWER_TEMPLATES):
        clash = sorted(set(more) & set(MANIP_TEMPLATES))
        if clash:
            raise ValueError(f"kb template keys defined twice: {clash}")
        MANIP_TEMPLATES.update(more)


_register_more()
