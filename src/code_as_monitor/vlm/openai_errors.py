"""Naming a server's error for what it is, with the fix, and deciding whether a retry can help.

Servers word their errors differently (OpenAI, vLLM, llama.cpp, Ollama); the classification reads the HTTP
status and the message:

====================================== ============================================ ==========
what                                   recognised by                                retried
====================================== ============================================ ==========
the model takes no images              4xx/5xx naming images, vision, multimodal,   no
                                       mmproj, image_url
the context is too small               4xx/5xx naming the context, n_ctx, too many  no
                                       tokens, maximum context length
structured output not supported        4xx/5xx naming response_format / json_schema falls back
                                                                                    to the next
                                                                                    format
the API key is rejected                401, 403                                     no
unknown model or wrong URL             404                                          no
any other 4xx                          400-499 but 429                              no
rate limit, server error               429, 5xx                                     yes
====================================== ============================================ ==========
"""

from __future__ import annotations

import re

from code_as_monitor.core.errors import (
    VLMConfigError,
    VLMContextError,
    VLMError,
    VLMImageError,
    VLMRequestError,
)

_IMAGE = re.compile(r"image|vision|multimodal|multi-modal|mmproj|clip model|image_url", re.I)
_CONTEXT = re.compile(r"context|n_ctx|too many tokens|too long|maximum .*length|exceeds? .*(tokens|limit)|"
                      r"prompt is too|max_tokens", re.I)
_FORMAT = re.compile(r"response_format|json_schema|json schema|grammar|guided|structured output", re.I)


def context_fix(max_tokens: int) -> str:
    """The fix for a context that is too small."""
    return (f"raise the server's context size (llama.cpp: -c / --ctx-size, llama-cpp-python: --n_ctx, vLLM: "
            f"--max-model-len, Ollama: num_ctx) or lower --max-tokens (now {max_tokens})")


def is_format_refusal(status: int, message: str) -> bool:
    """Does the server refuse the structured-output ``response_format`` (so the next format should be tried)?

    Any error status counts: llama-cpp-python's server answers a ``response_format`` it does not know with HTTP
    500 (its request validation error), not 4xx."""
    return status >= 400 and status != 429 and bool(_FORMAT.search(message)) and not _IMAGE.search(message)


def classify(status: int, message: str, where: str, key_env: str, max_tokens: int) -> VLMError | None:
    """The exception for an HTTP error, or None when a retry may help (429, other 5xx)."""
    msg = " ".join(message.split())[:300]
    if status in (401, 403):
        return VLMConfigError(f"{where}: the server rejected the API key from {key_env} (HTTP {status}): {msg}")
    if _IMAGE.search(msg) and (400 <= status < 600):
        return VLMImageError(f"{where}: the model does not accept images (HTTP {status}: {msg}); pass --no-images "
                             f"for a text-only model, or serve a vision model")
    if _CONTEXT.search(msg) and (400 <= status < 600):
        return VLMContextError(f"{where}: the prompt and the answer do not fit the server's context (HTTP "
                               f"{status}: {msg}); {context_fix(max_tokens)}")
    if status == 404:
        return VLMConfigError(f"{where}: HTTP 404 ({msg}); check --model (the name the server serves) and "
                              f"--base-url (it ends in /v1)")
    if 400 <= status < 500 and status != 429:
        return VLMRequestError(f"{where}: the server refused the request (HTTP {status}: {msg})")
    return None
