"""Turning model text into code and JSON: fence stripping and JSON extraction.

The errors raised here are :class:`~code_as_monitor.core.errors.VLMOutputError` with a message meant
to be sent back to the model verbatim ("your answer ... because ...").
"""

from __future__ import annotations

import json
import re
from typing import Any

from code_as_monitor.core.errors import VLMOutputError

# ```lang info\n body ``` ; lang and info are optional.
_FENCE_RE = re.compile(r"```[ \t]*([A-Za-z0-9_+-]*)[ \t]*([^\n`]*)\n(.*?)(?:\n[ \t]*```|\Z)", re.DOTALL)


def fenced_blocks(text: str) -> list[tuple[str, str, str]]:
    """All Markdown fenced blocks in ``text`` as ``(lang, info, body)``, in order."""
    return [(m.group(1).lower(), m.group(2).strip(), m.group(3)) for m in _FENCE_RE.finditer(text)]


def strip_code_fences(text: str, prefer: tuple[str, ...] = ("python", "py")) -> str:
    """The code in ``text``: the first fenced block whose language is in ``prefer`` (else the first
    fenced block), or the whole text when it has no fence. Leading/trailing blank lines are removed."""
    blocks = fenced_blocks(text)
    if not blocks:
        body = text
    else:
        chosen = next((b for b in blocks if b[0] in prefer), blocks[0])
        body = chosen[2]
    return body.strip("\n").rstrip() + "\n"


def extract_json(text: str) -> dict[str, Any]:
    """The JSON object in ``text``: a ```json fenced block, else the outermost ``{...}`` span.

    Raises:
        VLMOutputError: no JSON object, or it does not parse (the message says where).
    """
    candidates: list[str] = [b[2] for b in fenced_blocks(text) if b[0] in ("json", "")]
    start, end = text.find("{"), text.rfind("}")
    if start != -1 and end > start:
        candidates.append(text[start : end + 1])
    if not candidates:
        raise VLMOutputError("the answer contains no JSON object")
    last_error = ""
    for cand in candidates:
        try:
            value = json.loads(cand)
        except json.JSONDecodeError as exc:
            last_error = f"invalid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
            continue
        if isinstance(value, dict):
            return value
        last_error = f"expected a JSON object, got {type(value).__name__}"
    raise VLMOutputError(last_error)


def extract_request(text: str, tag: str = "request") -> dict[str, Any] | None:
    """The machine-readable request block (```json <tag>) embedded in a prompt, or None."""
    for lang, info, body in fenced_blocks(text):
        if lang == "json" and info == tag:
            value = json.loads(body)
            if isinstance(value, dict):
                return value
    return None


def dump_request(request: dict[str, Any], tag: str = "request") -> str:
    """Render ``request`` as the fenced block :func:`extract_request` reads back: compact JSON (no
    whitespace between tokens) in the request's own key order."""
    return f"```json {tag}\n{json.dumps(request, separators=(',', ':'))}\n```"
