# ruff: noqa: E501  (the bodies are generated code, kept one statement per line)
"""Monitor-code templates for the ``pour-tea`` constraints (same rules as :mod:`code_as_monitor.vlm.kb.templates`).

Element order in a constraint's parts is the contract with :mod:`code_as_monitor.vlm.kb.tea`: ``lid`` is a
SURFACE (the corners of the pot's lid; ``normal`` gives the pot's up axis, ``angle_to_vertical`` its tilt),
``spout`` a point (the trough's centre), ``rim`` a SURFACE (the cup's opening; its centroid is the cup's centre).
Level is the lid normal's angle to vertical (any direction). Tipped to pour is measured along the pot instead:
the slope of the line from the handle's centre to the spout's centre, about horizontal when the pot is level and
as steep as the forward tilt when it pours (measured on simulator frames: within 5 degrees of the pot's tilt). The
lid normal cannot tell a pot tipped spout-down from one tipped back, and a check that asks for a large tilt of a
surface from a level start is one that path coverage's probes (translations; a surface rotated on a few of them)
rarely drive to True, so the coder's program would be rejected; points moved up or down do drive it.
A tilt's direction in transport (along the spout or sideways) is not told apart: the kb levels the pot with the
wrist first and sets it down when that does not work (see :mod:`code_as_monitor.vlm.kb.tea`).
"""

from __future__ import annotations

from collections.abc import Callable

from code_as_monitor.vlm.kb.templates import Spec, _f, _fn, _name, _q


def potlevel(c: Spec) -> str:
    """Parts: [lid (surface)]. The lid's normal is within ``max_tilt`` of vertical (the pot stands level)."""
    (lid,) = c["element_ids"][:1]
    th, xn = c["thresholds"], _name(c, 0)
    mt = _f(th["max_tilt"])
    body = f"""
    a = angle_to_vertical(normal(E[{lid}]))
    if a <= {mt}:
        return True, {_q(xn + " is level (its lid %.1f degrees from horizontal)")} % math.degrees(a), {mt} - a
    return False, {_q(xn + " is not level: its lid is tilted %.1f degrees")} % math.degrees(a), {mt} - a
"""
    return _fn(c, body)


def spoutover(c: Spec) -> str:
    """Parts: [spout (point), rim (surface)]. The spout is above the cup: within ``max_offset`` horizontally."""
    spout, rim = c["element_ids"][:2]
    th, xn, rn = c["thresholds"], _name(c, 0), _name(c, 1)
    mo = _f(th["max_offset"])
    body = f"""
    off = horizontal_distance(E[{spout}], centroid(E[{rim}]))
    if off <= {mo}:
        return True, {_q("the spout of " + xn + " is above " + rn + " (%.3f m from its centre)")} % off, {mo} - off
    return False, {_q("the spout of " + xn + " is not above " + rn + ": %.3f m from its centre")} % off, {mo} - off
"""
    return _fn(c, body)


def _tilted(c: Spec, failure: str) -> str:
    """Parts: [handle (point), spout (point)]. The pot is tipped spout-down by at least ``min_tilt``: the line from
    the handle to the spout (about horizontal when the pot is level) slopes down that much. ``failure`` is the
    reason when it does not, with ``%.1f`` for the slope in degrees."""
    handle, spout = c["element_ids"][:2]
    th, xn = c["thresholds"], _name(c, 0)
    mt = _f(th["min_tilt"])
    body = f"""
    d = centroid(E[{spout}]) - centroid(E[{handle}])
    a = math.atan2(-d[2], math.hypot(d[0], d[1]))
    if a >= {mt}:
        return True, {_q(xn + " is tipped to pour: its spout %.1f degrees below its handle")} % math.degrees(a), a - {mt}
    return False, {_q(xn + failure)} % math.degrees(a), a - {mt}
"""
    return _fn(c, body)


def pourtilt(c: Spec) -> str:
    """Upon the pour: tilted past the pour angle."""
    return _tilted(c, " is tipped only %.1f degrees spout-down: not past the pour angle, the tea does not run out")


def draintilt(c: Spec) -> str:
    """During the drain: still tilted past the pour angle."""
    return _tilted(c, " went back towards level (spout %.1f degrees below the handle) while draining: the tea stops running")


TEA_TEMPLATES: dict[str, Callable[[Spec], str]] = {
    "potlevel": potlevel, "spoutover": spoutover, "pourtilt": pourtilt, "draintilt": draintilt,
}
"""Template key (constraint id prefix) -> writer, for the ``pour-tea`` constraints."""
