"""``openai``: any OpenAI-compatible chat-completions server through the ``openai`` SDK.

GPT-4o, and local servers such as vLLM, Ollama or llama.cpp (``base_url`` ending in ``/v1``). Images
go as PNG base64 data URLs. The SDK's own retries are off; this backend retries 429, 5xx, timeouts and
connection errors itself, a bounded number of times with exponential backoff (honouring a
``Retry-After`` header), and takes token usage from the response.
"""

from __future__ import annotations

import base64
import logging
import os
import time
from typing import Any

from code_as_monitor.core.errors import VLMConfigError, VLMError
from code_as_monitor.vlm.backend import OpenAIBackendConfig, VLMResponse
from code_as_monitor.vlm.messages import ImagePart, Message
from code_as_monitor.vlm.usage import estimate_prompt_tokens, estimate_tokens

log = logging.getLogger(__name__)

NO_KEY = "none"
"""``api_key_env`` value for servers that need no key."""


def png_data_url(image: ImagePart) -> str:
    """``data:image/png;base64,...`` of an RGB image."""
    import cv2

    ok, buf = cv2.imencode(".png", image.rgb[:, :, ::-1])
    if not ok:
        raise VLMError(f"could not PNG-encode image {image.label!r} of shape {image.rgb.shape}")
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode("ascii")


def to_openai_messages(messages: list[Message], detail: str = "auto") -> list[dict[str, Any]]:
    """Chat-completions message dicts; a text-only message becomes a plain string content."""
    out: list[dict[str, Any]] = []
    for m in messages:
        if not m.images:
            out.append({"role": m.role, "content": m.text})
            continue
        parts: list[dict[str, Any]] = []
        for p in m.content:
            if isinstance(p, ImagePart):
                parts.append({"type": "image_url", "image_url": {"url": png_data_url(p), "detail": detail}})
            else:
                parts.append({"type": "text", "text": p.text})
        out.append({"role": m.role, "content": parts})
    return out


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


def _retry_after(exc: Exception) -> float | None:
    response = getattr(exc, "response", None)
    headers = getattr(response, "headers", None)
    if headers is None:
        return None
    value = headers.get("retry-after")
    try:
        return max(0.0, float(value)) if value is not None else None
    except ValueError:
        return None


class OpenAIBackend:
    """Chat completions against an OpenAI-compatible server (see the module docstring)."""

    def __init__(self, config: OpenAIBackendConfig | None = None) -> None:
        import openai

        self.config = config or OpenAIBackendConfig()
        self._openai = openai
        self.client = openai.OpenAI(
            api_key=resolve_api_key(self.config.api_key_env),
            base_url=self.config.base_url,
            timeout=self.config.timeout_s,
            max_retries=0,
        )
        self.where = f"{self.config.model} at {self.config.base_url or 'api.openai.com'}"

    def _delay(self, attempt: int, exc: Exception | None) -> float:
        """Seconds before retry ``attempt + 1``: the server's Retry-After, else exponential, both capped."""
        ra = _retry_after(exc) if exc is not None else None
        base = self.config.backoff_base_s * (2**attempt)
        return min(self.config.backoff_max_s, ra if ra is not None else base)

    def complete(self, messages: list[Message], *, purpose: str) -> VLMResponse:
        openai = self._openai
        payload = to_openai_messages(messages, self.config.image_detail)
        attempts = 1 + self.config.max_retries
        last = ""
        for attempt in range(attempts):
            try:
                resp = self.client.chat.completions.create(
                    model=self.config.model,
                    messages=payload,  # type: ignore[arg-type]
                    temperature=self.config.temperature,
                    max_tokens=self.config.max_tokens,
                )
            except openai.APITimeoutError:
                last = f"timed out after {self.config.timeout_s:g} s"
                retry_exc: Exception | None = None
            except openai.APIConnectionError as exc:
                last = f"cannot connect to the server ({exc.__cause__ or exc})"
                retry_exc = None
            except openai.AuthenticationError as exc:
                raise VLMConfigError(
                    f"{self.where}: the server rejected the API key from {self.config.api_key_env} "
                    f"(HTTP {exc.status_code})"
                ) from None
            except openai.APIStatusError as exc:
                if exc.status_code != 429 and exc.status_code < 500:
                    raise VLMError(f"{self.where}: HTTP {exc.status_code}: {_short(exc)}") from None
                last = f"HTTP {exc.status_code}: {_short(exc)}"
                retry_exc = exc
            else:
                return self._response(resp, messages)
            if attempt + 1 < attempts:
                delay = self._delay(attempt, retry_exc)
                log.info("%s (%s): %s; retry %d/%d in %.2f s", self.where, purpose, last, attempt + 1,
                            self.config.max_retries, delay)
                time.sleep(delay)
        raise VLMError(f"{self.where}: gave up after {attempts} attempt(s): {last}")

    def _response(self, resp: Any, messages: list[Message]) -> VLMResponse:
        try:
            text = resp.choices[0].message.content or ""
        except (AttributeError, IndexError, TypeError):
            raise VLMError(f"{self.where}: malformed response without choices[0].message") from None
        usage = getattr(resp, "usage", None)
        if usage is not None and usage.prompt_tokens is not None:
            return VLMResponse(text, int(usage.prompt_tokens), int(usage.completion_tokens or 0),
                               str(getattr(resp, "model", "") or self.config.model))
        return VLMResponse(text, estimate_prompt_tokens(messages), estimate_tokens(text),
                           str(getattr(resp, "model", "") or self.config.model), estimated=True)


def _short(exc: Exception, limit: int = 200) -> str:
    msg = getattr(exc, "message", None) or str(exc)
    msg = " ".join(str(msg).split())
    return msg if len(msg) <= limit else msg[: limit - 3] + "..."
