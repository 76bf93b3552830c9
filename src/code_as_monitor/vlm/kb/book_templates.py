# ruff: noqa: E501  (the bodies are generated code, kept one statement per line)
"""Monitor-code templates for the book (line-level) constraints: the spine is a LINE element.

Same rules as :mod:`code_as_monitor.vlm.kb.templates`. Element order in a constraint's parts is the
contract with :mod:`code_as_monitor.vlm.kb.book`: ``cover`` is a point (the book's centre, where the
gripper holds it), ``spine`` a line (its two ends), ``slot`` a surface (the slot rim's corners). The book's
lower end is the lower of the spine's lowest end and the centre minus half the book's height
(``half_height``): a finger over the spine can shorten the painted line.
"""

from __future__ import annotations

from collections.abc import Callable

from code_as_monitor.vlm.kb.templates import Spec, _f, _fn, _name, _q, _tilt


def aligned(c: Spec) -> str:
    """Parts: [spine (line)]. The spine lies as it did: within ``max_turn`` of its oldest direction in H and
    its slope within ``max_slope`` of its oldest slope (a book lying flat stays flat; a book left leaning
    in the shelf is judged against its lean, not against the table), unless the whole spine is above
    ``held_z`` (the book is already up in the gripper)."""
    (x,) = c["element_ids"][:1]
    th, xn = c["thresholds"], _name(c, 0)
    mt, ms, hz = _f(th["max_turn"]), _f(th["max_slope"]), _f(th["held_z"])
    body = f"""
    a = angle_between(direction(H[{x}][0]), direction(E[{x}]))
    a = np.min([a, math.pi - a])
    s = np.abs(angle_to_vertical(direction(E[{x}])) - angle_to_vertical(direction(H[{x}][0])))
    low = np.min(E[{x}][:, 2])
    margin = np.max([np.min([{mt} - a, {ms} - s]), low - {hz}])
    if (a <= {mt} and s <= {ms}) or low > {hz}:
        return True, {_q(xn + " spine lies as it did (turned %.1f degrees, its slope changed %.1f degrees)")} % (math.degrees(a), math.degrees(s)), margin
    return False, {_q(xn + " spine turned %.1f degrees (its slope changed %.1f degrees) while the gripper approached: the jaws will close across a skewed " + xn)} % (math.degrees(a), math.degrees(s)), margin
"""
    return _fn(c, body)


def raised(c: Spec) -> str:
    """Parts: [cover (point)]. The book's centre is at least ``min_rise`` above where it was in the oldest frame
    of H (the grasp's start): it has been picked up, wherever it lay."""
    (x,) = c["element_ids"][:1]
    th, xn = c["thresholds"], _name(c, 0)
    mr = _f(th["min_rise"])
    body = f"""
    rise = centroid(E[{x}])[2] - centroid(H[{x}][0])[2]
    if rise >= {mr}:
        return True, {_q(xn + " is picked up: it rose %.3f m since the grasp began")} % rise, rise - {mr}
    return False, {_q(xn + " is not picked up: it rose only %.3f m since the grasp began (needs " + mr + ")")} % rise, rise - {mr}
"""
    return _fn(c, body)


def conveyed(c: Spec) -> str:
    """Parts: [gripper tip (point), cover (point), spine (line), slot (surface)]. The book stays at the grasp
    point unless it already stands low in the slot (it was let go there)."""
    tip, cov, sp, slot = c["element_ids"][:4]
    th, xn, sn = c["thresholds"], _name(c, 1), _name(c, 3)
    md, mo, dp = _f(th["max_dist"]), _f(th["max_offset"]), _f(th["min_depth"])
    hh = _f(th["half_height"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{cov}]))
    depth = centroid(E[{slot}])[2] - np.min([np.min(E[{sp}][:, 2]), centroid(E[{cov}])[2] - {hh}])
    off = horizontal_distance(centroid(E[{cov}]), centroid(E[{slot}]))
    margin = np.max([{md} - d, np.min([{mo} - off, depth - {dp}])])
    if d <= {md} or (off <= {mo} and depth >= {dp}):
        return True, {_q(xn + " is in the gripper or already in the slot of " + sn + " (%.3f m from the grasp point)")} % d, margin
    return False, {_q(xn + " dropped: it is %.3f m from the grasp point and not in the slot of " + sn + " (offset %.3f m, %.3f m below the rim)")} % (d, off, depth), margin
"""
    return _fn(c, body)


def poised(c: Spec) -> str:
    """Parts: [gripper tip (point), cover (point), spine (line), slot (surface)]. While held and not yet in
    the slot, the spine stays near vertical (a book leaning in the slot is the upon check's business)."""
    tip, cov, sp, slot = c["element_ids"][:4]
    th, xn = c["thresholds"], _name(c, 1)
    md, mt, dp = _f(th["max_dist"]), _f(th["max_tilt"]), _f(th["min_depth"])
    hh = _f(th["half_height"])
    body = f"""
    a = angle_to_vertical(direction(E[{sp}]))
    d = distance(E[{tip}], centroid(E[{cov}]))
    depth = centroid(E[{slot}])[2] - np.min([np.min(E[{sp}][:, 2]), centroid(E[{cov}])[2] - {hh}])
    margin = np.max([{mt} - a, d - {md}, depth - {dp}])
    if a <= {mt} or d > {md} or depth >= {dp}:
        return True, {_q(xn + " spine is near vertical while carried (%.1f degrees), or it is not held, or already in the slot")} % math.degrees(a), margin
    return False, {_q(xn + " is tilted in the gripper: its spine is %.1f degrees from vertical, not upright")} % math.degrees(a), margin
"""
    return _fn(c, body)


def aimed(c: Spec) -> str:
    """Parts: [cover (point), spine (line), slot (surface)]. Entering the slot (the lower end between the rim
    and ``deep`` below it) means centred over it; deeper in, the upon checks judge it."""
    cov, sp, slot = c["element_ids"][:3]
    th, xn, sn = c["thresholds"], _name(c, 0), _name(c, 2)
    ap, mo, dd = _f(th["approach"]), _f(th["max_offset"]), _f(th["deep"])
    hh = _f(th["half_height"])
    body = f"""
    h = np.min([np.min(E[{sp}][:, 2]), centroid(E[{cov}])[2] - {hh}]) - centroid(E[{slot}])[2]
    off = horizontal_distance(centroid(E[{cov}]), centroid(E[{slot}]))
    margin = np.max([h - {ap}, {mo} - off, -h - {dd}])
    if h >= {ap} or off <= {mo} or h < -{dd}:
        return True, {_q(xn + " is above the slot of " + sn + " or still high (offset %.3f m, %.3f m above the rim)")} % (off, h), margin
    return False, {_q(xn + " is %.3f m above the rim but offset %.3f m from the slot of " + sn + ": not above the opening, it will miss it")} % (h, off), margin
"""
    return _fn(c, body)


def shelved(c: Spec) -> str:
    """Parts: [cover (point), spine (line), slot (surface)]. The book's lower end is in the slot, below the rim."""
    cov, sp, slot = c["element_ids"][:3]
    th, xn, sn = c["thresholds"], _name(c, 0), _name(c, 2)
    mo, dp = _f(th["max_offset"]), _f(th["min_depth"])
    hh = _f(th["half_height"])
    body = f"""
    depth = centroid(E[{slot}])[2] - np.min([np.min(E[{sp}][:, 2]), centroid(E[{cov}])[2] - {hh}])
    off = horizontal_distance(centroid(E[{cov}]), centroid(E[{slot}]))
    margin = np.min([{mo} - off, depth - {dp}])
    if off <= {mo} and depth >= {dp}:
        return True, {_q(xn + " is in the slot of " + sn + " (%.3f m below the rim, offset %.3f m)")} % (depth, off), margin
    return False, {_q(xn + " is not inside the slot of " + sn + ": %.3f m below the rim (needs " + dp + "), offset %.3f m from its centre")} % (depth, off), margin
"""
    return _fn(c, body)


def standing(c: Spec) -> str:
    """Parts: [spine (line)]. The spine is within ``max_tilt`` of vertical."""
    return _tilt(c, "standing", "direction")


BOOK_TEMPLATES: dict[str, Callable[[Spec], str]] = {
    "aligned": aligned, "raised": raised, "conveyed": conveyed, "poised": poised, "aimed": aimed, "shelved": shelved, "standing": standing,
}
"""Template key (constraint id prefix) -> writer, for the book constraints."""
