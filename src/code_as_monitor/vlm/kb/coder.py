"""The kb's monitor coder: one template-written check per constraint of the coder request."""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import VLMError
from code_as_monitor.vlm.kb.manip_templates import MANIP_TEMPLATES
from code_as_monitor.vlm.kb.templates import write_check


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
        key = str(c.get("id", "")).split("_", 1)[0]
        chunks.append(MANIP_TEMPLATES[key](c) if key in MANIP_TEMPLATES else write_check(c))
    return "\n\n".join(chunks)
