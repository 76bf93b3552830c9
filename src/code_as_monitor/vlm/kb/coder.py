"""The kb's monitor coder: one template-written check per constraint of the coder request."""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import VLMError
from code_as_monitor.vlm.kb.registry import all_keywords, all_templates
from code_as_monitor.vlm.kb.shared.codegen import Spec


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


def write_program(request: dict[str, Any]) -> str:
    """Program source for a coder request ``{subgoal, constraints: [...with element_ids], elements}``."""
    cons = request.get("constraints") or []
    if not cons:
        raise VLMError("kb: the coder request has no constraints")
    chunks = [
        f"# Monitor program for: {request.get('subgoal', '')}\n"
        "# Written by the kb (rule-based templates, not a VLM).\n"
    ]
    for c in cons:
        ids, parts = c.get("element_ids") or [], c.get("parts") or []
        if len(ids) != len(parts):
            raise VLMError(f"kb: constraint {c.get('id')!r} has {len(ids)} element ids for {len(parts)} parts")
        chunks.append(write_check(c))
    return "\n\n".join(chunks)
