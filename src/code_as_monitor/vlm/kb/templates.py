# ruff: noqa: E501  (the bodies are generated code, kept one statement per line)
"""Monitor-code templates: one small function per constraint kind, filled with element ids and thresholds.

The template key is the prefix of the constraint id (``held_green_block`` -> ``held``); ids without a
known prefix fall back to keywords in the constraint text. Generated code uses only ``np``, ``math``
and the monitor helpers, returns literal ``True``/``False`` from explicit branches (so path-coverage
testing can reach every branch: one decision per check, its reason carrying every measurement) and formats reasons with ``%`` (no builtins needed).
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from typing import Any

from code_as_monitor.core.errors import VLMError

Spec = dict[str, Any]
"""A constraint from the coder request: id, text, phase, thresholds, parts, element_ids."""


def _f(x: float) -> str:
    return repr(float(x))


def _q(s: str) -> str:
    """A Python string literal for ``s`` (object names never contain ``%``)."""
    return repr(s)


def _head(c: Spec) -> str:
    items = [f"E[{i}] = {p['name']} ({p['kind']})" for i, p in zip(c["element_ids"], c["parts"])]
    if len(items) > 6:
        items = [*items[:3], f"... {len(items) - 4} more ...", items[-1]]
    legend = "; ".join(items)
    return f"def check_{c['id']}(E, H, t):\n    # {c['text']}\n    # {legend}\n"


def _fn(c: Spec, body: str) -> str:
    """``def check_<id>`` with a comment header and ``body`` (written at zero indent) indented."""
    return _head(c) + textwrap.indent(textwrap.dedent(body).strip("\n"), "    ") + "\n"


def _name(c: Spec, k: int) -> str:
    return str(c["parts"][k]["obj"])


def held(c: Spec) -> str:
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], _name(c, 1)
    md, mz = _f(th["max_dist"]), _f(th["min_z"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    z = centroid(E[{x}])[2]
    margin = np.min([{md} - d, z - {mz}])
    if d <= {md} and z >= {mz}:
        return True, {_q(xn + " is held by the suction cup (%.3f m from the tip, lifted to %.3f m)")} % (d, z), margin
    return False, {_q(xn + " is not held by the suction cup: %.3f m from the tip (limit " + md + "), centre %.3f m above the table (needs " + mz + ")")} % (d, z), margin
"""
    return _fn(c, body)


def attached(c: Spec) -> str:
    tip, x, tgt = c["element_ids"][:3]
    th, xn, tn = c["thresholds"], _name(c, 1), _name(c, 2)
    md, rxy, lo, hi = _f(th["max_dist"]), _f(th["release_xy"]), _f(th["min_dz"]), _f(th["max_dz"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    off = horizontal_distance(E[{x}], E[{tgt}])
    dz = centroid(E[{x}])[2] - centroid(E[{tgt}])[2]
    margin = np.max([{md} - d, np.min([{rxy} - off, dz - {lo}, {hi} - dz])])
    if d <= {md} or (off <= {rxy} and dz >= {lo} and dz <= {hi}):
        return True, {_q(xn + " is on the suction cup or was released onto " + tn + " (%.3f m from the tip)")} % d, margin
    return False, {_q(xn + " dropped: detached from the suction cup (%.3f m from the tip) before resting on " + tn)} % d, margin
"""
    return _fn(c, body)


def still(c: Spec) -> str:
    (tgt,) = c["element_ids"][:1]
    th, tn = c["thresholds"], _name(c, 0)
    mx = _f(th["max_disp"])
    body = f"""
    m = displacement(H[{tgt}])
    if m <= {mx}:
        return True, {_q(tn + " stays in place (moved %.3f m)")} % m, {mx} - m
    return False, {_q(tn + " moved %.3f m: the tower below is disturbed and stacking on it will topple")} % m, {mx} - m
"""
    return _fn(c, body)


def centred(c: Spec) -> str:
    x, tgt = c["element_ids"][:2]
    th, xn, tn = c["thresholds"], _name(c, 0), _name(c, 1)
    mo = _f(th["max_offset"])
    body = f"""
    off = horizontal_distance(E[{x}], E[{tgt}])
    if off <= {mo}:
        return True, {_q(xn + " is centred on " + tn + " (offset %.3f m)")} % off, {mo} - off
    return False, {_q(xn + " is offset %.3f m from the centre of " + tn + " (limit " + mo + "): stacking on it will topple")} % off, {mo} - off
"""
    return _fn(c, body)


def resting(c: Spec) -> str:
    x, tgt = c["element_ids"][:2]
    th, xn, tn = c["thresholds"], _name(c, 0), _name(c, 1)
    lo, hi = _f(th["min_dz"]), _f(th["max_dz"])
    body = f"""
    dz = centroid(E[{x}])[2] - centroid(E[{tgt}])[2]
    margin = np.min([dz - {lo}, {hi} - dz])
    if dz >= {lo} and dz <= {hi}:
        return True, {_q(xn + " rests on " + tn + " (%.3f m above its centre)")} % dz, margin
    return False, {_q(xn + " is not resting on " + tn + ": its centre is %.3f m above the centre of " + tn + " (expected " + lo + " to " + hi + ")")} % dz, margin
"""
    return _fn(c, body)


def released(c: Spec) -> str:
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], _name(c, 1)
    rd = _f(th["release_dist"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    if d >= {rd}:
        return True, {_q(xn + " is released (the tip is %.3f m away)")} % d, d - {rd}
    return False, {_q(xn + " is still held by the suction cup (the tip is %.3f m from its centre)")} % d, d - {rd}
"""
    return _fn(c, body)


def tower(c: Spec) -> str:
    up, lo_id = c["element_ids"][:2]
    th, un, ln = c["thresholds"], _name(c, 0), _name(c, 1)
    mo, lo, hi = _f(th["max_offset"]), _f(th["min_dz"]), _f(th["max_dz"])
    body = f"""
    off = horizontal_distance(E[{up}], E[{lo_id}])
    dz = centroid(E[{up}])[2] - centroid(E[{lo_id}])[2]
    margin = np.min([{mo} - off, dz - {lo}, {hi} - dz])
    if off <= {mo} and dz >= {lo} and dz <= {hi}:
        return True, {_q(un + " is still on " + ln + " (offset %.3f m)")} % off, margin
    return False, {_q(un + " is no longer on " + ln + " (offset %.3f m, height difference %.3f m): the tower collapsed")} % (off, dz), margin
"""
    return _fn(c, body)


def _blocks_and_zone(c: Spec) -> tuple[int, list[int]]:
    ids = c["element_ids"]
    zone = next(i for i, p in zip(ids, c["parts"]) if p["kind"] == "surface")
    return zone, [i for i, p in zip(ids, c["parts"]) if p["kind"] == "point"]


def reached(c: Spec) -> str:
    zone, blocks = _blocks_and_zone(c)
    th = c["thresholds"]
    tgt, total = int(th["target"]), len(blocks)
    body = f"""
    n = count_in_polygon([E[i] for i in {tuple(blocks)!r}], E[{zone}])
    if n >= {tgt}:
        return True, "%d of {total} blocks are inside the zone (target {tgt})" % n, n - {tgt} + 0.5
    return False, "only %d of {total} blocks are inside the zone (target {tgt})" % n, n - {tgt} + 0.5
"""
    return _fn(c, body)


def capped(c: Spec) -> str:
    zone, blocks = _blocks_and_zone(c)
    up = int(c["thresholds"]["upper"])
    body = f"""
    n = count_in_polygon([E[i] for i in {tuple(blocks)!r}], E[{zone}])
    if n <= {up}:
        return True, "%d blocks are inside the zone (at most {up})" % n, {up} - n + 0.5
    return False, "%d blocks are inside the zone, more than {up}" % n, {up} - n + 0.5
"""
    return _fn(c, body)


def covers(c: Spec) -> str:
    c0, c3 = c["element_ids"][:2]
    beads = tuple(c["element_ids"][2:])
    th = c["thresholds"]
    gap, n, mz, frac = _f(th["max_gap"]), int(th["samples"]), _f(th["max_z"]), _f(th["min_fraction"])
    win = _f(th["stable_s"])
    body = f"""
    s = np.linspace(0.0, 1.0, {n})
    covered = 1.0
    for j in np.nonzero(H.t >= t - {win})[0]:
        a = centroid(H[{c0}][j])
        b = centroid(H[{c3}][j])
        samples = a[None, :2] + s[:, None] * (b - a)[None, :2]
        beads = np.array([centroid(H[i][j]) for i in {beads!r}])
        carried = np.maximum(beads[:, 2] - {mz}, 0.0) * 1000.0
        d = np.sqrt(np.sum((samples[:, None, :] - beads[None, :, :2]) ** 2, axis=2)) + carried[None, :]
        covered = min(covered, float(np.mean(np.min(d, axis=1) <= {gap})))
    if covered >= {frac}:
        return True, "the rope has closed the opening for {win} s (at least %.0f%% of it within {gap} m of a resting bead)" % (100 * covered), covered - {frac} + 0.5 / {n}
    return False, "the opening of the square is not enclosed steadily: over the last {win} s as little as %.0f%% of it was within {gap} m of a resting rope bead" % (100 * covered), covered - {frac} + 0.5 / {n}
"""
    return _fn(c, body)


def _tilt(c: Spec, what: str, vec: str) -> str:
    (el,) = c["element_ids"][:1]
    tol, n = c["thresholds"]["max_tilt"], _name(c, 0)
    body = f"""
    a = angle_to_vertical({vec}(E[{el}]))
    if a <= {_f(tol)}:
        return True, {_q(n + " is " + what + " (%.1f degrees)")} % math.degrees(a), {_f(tol)} - a
    return False, {_q(n + " is not " + what + ": %.1f degrees from vertical")} % math.degrees(a), {_f(tol)} - a
"""
    return _fn(c, body)


def upright(c: Spec) -> str:
    return _tilt(c, "upright", "direction")


def level(c: Spec) -> str:
    return _tilt(c, "level", "normal")


TEMPLATES: dict[str, Callable[[Spec], str]] = {
    "held": held, "attached": attached, "still": still, "centred": centred, "resting": resting,
    "released": released, "tower": tower,
    "reached": reached, "capped": capped, "rope": covers, "upright": upright, "level": level,
}
KEYWORDS: tuple[tuple[str, str], ...] = (
    ("held by", "held"), ("attached", "attached"), ("stays in place", "still"), ("centred", "centred"),
    ("rests on", "resting"), ("released", "released"),
    ("still on", "tower"), ("inside", "reached"), ("rope", "rope"), ("upright", "upright"), ("level", "level"),
)


def template_key(c: Spec) -> str:
    """The template for constraint ``c``: its id prefix, else a keyword of its text."""
    prefix = str(c["id"]).split("_", 1)[0]
    if prefix in TEMPLATES:
        return prefix
    text = str(c.get("text", "")).lower()
    for word, key in KEYWORDS:
        if word in text:
            return key
    raise VLMError(f"kb: no code template for constraint {c['id']!r} ({c.get('text', '')!r})")


def write_check(c: Spec) -> str:
    """The source of ``check_<id>`` for constraint ``c``."""
    return TEMPLATES[template_key(c)](c)
