"""What the ``openai`` backend sends: chat messages with PNG images, the response format, the API key."""

from __future__ import annotations

import base64
import os
from typing import Any

from code_as_monitor.core.errors import VLMConfigError, VLMError
from code_as_monitor.vlm.messages import ImagePart, Message

NO_KEY = "none"
"""``api_key_env`` value for servers that need no key."""


def png_data_url(image: ImagePart) -> str:
    """``data:image/png;base64,...`` of an RGB image."""
    import cv2

    ok, buf = cv2.imencode(".png", image.rgb[:, :, ::-1])
    if not ok:
        raise VLMError(f"could not PNG-encode image {image.label!r} of shape {image.rgb.shape}")
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode("ascii")


def to_openai_messages(messages: list[Message], detail: str = "auto", images: bool = True) -> list[dict[str, Any]]:
    """Chat-completions message dicts; a text-only message (or every message, ``images=False``) becomes a plain
    string content. Without images, the image's label stays in the text as "(image <label> not sent)". Each
    image goes at its own detail, else at ``detail``."""
    out: list[dict[str, Any]] = []
    for m in messages:
        if not m.images:
            out.append({"role": m.role, "content": m.text})
            continue
        if not images:
            text = "\n".join(p.text if not isinstance(p, ImagePart) else f"(image {p.label} not sent)"
                             for p in m.content)
            out.append({"role": m.role, "content": text})
            continue
        parts: list[dict[str, Any]] = []
        for p in m.content:
            if isinstance(p, ImagePart):
                parts.append({"type": "image_url", "image_url": {"url": png_data_url(p), "detail": p.detail or detail}})
            else:
                parts.append({"type": "text", "text": p.text})
        out.append({"role": m.role, "content": parts})
    return out


def response_format(schema: dict[str, Any] | None, mode: str) -> dict[str, Any] | None:
    """The ``response_format`` for ``schema`` in ``mode``: ``json_schema`` (OpenAI, vLLM, Ollama, llama.cpp's
    server), ``json_object`` with the schema alongside (llama-cpp-python's server turns it into a grammar), or
    None (``off``, or no schema)."""
    if schema is None or mode == "off":
        return None
    if mode == "json_schema":
        name = str(schema.get("title") or "answer").replace(" ", "_")[:64]
        return {"type": "json_schema", "json_schema": {"name": name, "schema": schema, "strict": False}}
    return {"type": "json_object", "schema": schema}


def resolve_api_key(env_name: str) -> str:
    """The API key from environment variable ``env_name`` (``"none"``: a placeholder for keyless servers)."""
    if env_name.lower() == NO_KEY:
        return "no-key"
    key = os.environ.get(env_name, "").strip()
    if not key:
        raise VLMConfigError(
            f"environment variable {env_name} is not set: export it with your API key, or pass "
            f"--api-key-env none for a local server that needs no key"
        )
    return key
