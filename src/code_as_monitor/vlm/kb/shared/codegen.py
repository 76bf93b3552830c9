
"""Helpers for monitor-code templates, and the templates every family may use (``upright``, ``level``).

A template is one small function per constraint kind that writes ``check_<id>(E, H, t)`` from the constraint's
element ids and thresholds; its key is the constraint id's prefix (``held_green_block`` -> ``held``). Generated
code uses only ``np``, ``math`` and the monitor helpers, returns literal ``True``/``False`` from explicit
branches (so path-coverage testing can reach every branch: one decision per check, its reason carrying every
measurement) and formats reasons with ``%`` (no builtins needed).
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from typing import Any

Spec = dict[str, Any]
"""A constraint from the coder request: id, text, phase, thresholds, parts, element_ids."""

Template = Callable[[Spec], str]
"""Writes the source of ``check_<id>`` for one constraint."""


def num(x: float) -> str:
    """A float literal for generated code."""
    return repr(float(x))


def lit(s: str) -> str:
    """A Python string literal for ``s`` (object names never contain ``%``)."""
    return repr(s)


def check_fn(c: Spec, body: str) -> str:
    """``def check_<id>`` with ``body`` (written at zero indent) indented; no comments (the prompt asks for none)."""
    return f"def check_{c['id']}(E, H, t):\n" + textwrap.indent(textwrap.dedent(body).strip("\n"), "    ") + "\n"


def obj_name(c: Spec, k: int) -> str:
    """The object name of part ``k`` of constraint ``c``."""
    return str(c["parts"][k]["obj"])


def tilt(c: Spec, what: str, vec: str) -> str:
    """Parts: [element]. ``vec`` (``direction`` of a line, ``normal`` of a surface) within ``max_tilt`` of vertical."""
    (el,) = c["element_ids"][:1]
    tol, n = c["thresholds"]["max_tilt"], obj_name(c, 0)
    body = f"""
    a = angle_to_vertical({vec}(E[{el}]))
    if a <= {num(tol)}:
        return True, {lit(n + " is " + what + " (%.1f degrees)")} % math.degrees(a), {num(tol)} - a
    return False, {lit(n + " is not " + what + ": %.1f degrees from vertical")} % math.degrees(a), {num(tol)} - a
"""
    return check_fn(c, body)


def upright(c: Spec) -> str:
    """Parts: [line]. The line is within ``max_tilt`` of vertical."""
    return tilt(c, "upright", "direction")


def level(c: Spec) -> str:
    """Parts: [surface]. The surface's normal is within ``max_tilt`` of vertical."""
    return tilt(c, "level", "normal")


TEMPLATES: dict[str, Template] = {"upright": upright, "level": level}
KEYWORDS: tuple[tuple[str, str], ...] = (("upright", "upright"), ("level", "level"))
"""Fallbacks for constraint ids without a known prefix: a word in the constraint text -> template key."""
