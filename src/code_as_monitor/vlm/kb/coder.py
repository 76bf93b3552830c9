"""The kb's monitor coder: one template-written check per constraint of the coder request."""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import VLMError
from code_as_monitor.vlm.kb.registry import all_keywords, all_templates
from code_as_monitor.vlm.kb.shared.codegen import Spec
from code_as_monitor.vlm.kb.shared.points_only import group_points, grouped_spec, is_points_only, recombine


def template_key(c: Spec) -> str:
    """The template for constraint ``c``: its id prefix, else a keyword of its text."""
    templates = all_templates()
    prefix = str(c["id"]).split("_", 1)[0]
    if prefix in templates:
        return prefix
    text = str(c.get("text", "")).lower()
    for word, key in all_keywords():
        if word in text:
            return key
    raise VLMError(f"kb: no code template for constraint {c['id']!r} ({c.get('text', '')!r})")


def write_check(c: Spec) -> str:
    """The source of ``check_<id>`` for constraint ``c``."""
    return all_templates()[template_key(c)](c)


def legend(request: dict[str, Any]) -> dict[int, dict[str, str]]:
    """Element id -> part ``{name, obj, part, kind}`` from the request's legend ``[id, kind, "object/part"]`` or
    ``[id, kind, "object/part", name]`` (without a name, the owner's words are its name)."""
    out: dict[int, dict[str, str]] = {}
    for row in request.get("elements") or []:
        if not isinstance(row, list) or len(row) not in (3, 4):
            raise VLMError(f"kb: legend entry {row!r} is not [id, kind, object/part(, name)]")
        eid, kind, owner = row[:3]
        obj, _, part = str(owner).partition("/")
        name = str(row[3]) if len(row) == 4 else " ".join(w for w in (obj.replace("_", " "), part) if w)
        out[int(eid)] = {"name": str(name), "obj": obj, "part": part, "kind": str(kind)}
    return out


def write_program(request: dict[str, Any]) -> str:
    """Program source for a coder request ``{subgoal, constraints: [...with element_ids], elements}`` (each
    constraint's parts are read back from the legend by its element ids). As the prompt asks, the program has
    no comments but one line naming the kb as its author. A request whose elements are all points split from
    parts (the ablation "CP off") gets point-only checks (:mod:`~code_as_monitor.vlm.kb.shared.points_only`)."""
    cons = request.get("constraints") or []
    if not cons:
        raise VLMError("kb: the coder request has no constraints")
    elements = legend(request)
    points_only = is_points_only(elements)  # no lines or surfaces: recombine the points in code
    chunks = ["# by the kb, a rule-based stand-in (not a VLM)\n"]
    for c in cons:
        ids = c.get("element_ids") or []
        missing = [i for i in ids if i not in elements]
        if not ids or missing:
            raise VLMError(f"kb: constraint {c.get('id')!r} refers to elements {missing or ids} not in the legend")
        if points_only:
            groups = group_points([int(i) for i in ids], elements)
            chunks.append(recombine(write_check(grouped_spec(c, groups, elements)), groups))
        else:
            chunks.append(write_check({**c, "parts": [elements[i] for i in ids]}))
    return "\n".join(chunks)
