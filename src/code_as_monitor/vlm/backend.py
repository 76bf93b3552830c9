"""The VLM backend protocol, its registered configs and the factory.

One interface: a list of :class:`~code_as_monitor.vlm.messages.Message` in, a :class:`VLMResponse`
(text plus token usage) out. Backends are registered choices on :class:`VLMBackendConfig`:

- ``openai``: any OpenAI-compatible chat-completions server (GPT-4o, vLLM, Ollama, llama.cpp).
- ``kb``: the offline knowledge base, a rule-based stand-in for a VLM (not a VLM).
- ``replay``: records another backend's requests and responses to a JSONL cassette and replays them.

Implementations are imported by name, lazily, by :func:`make_backend` (:data:`IMPLEMENTATIONS`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.registry import Choice, build_lazily, check_positive
from code_as_monitor.vlm.messages import Message


@dataclass(frozen=True)
class VLMResponse:
    """What a backend returns for one request.

    Attributes:
        text: the answer text.
        prompt_tokens, completion_tokens: token usage as reported by the server (or estimated,
            see ``estimated``).
        model: the model that answered (``kb-rules-v1`` for the knowledge base).
        estimated: True when the token counts are estimates (the kb, or a server without usage).
    """

    text: str
    prompt_tokens: int = 0
    completion_tokens: int = 0
    model: str = ""
    estimated: bool = False

    def to_dict(self) -> dict:
        return {
            "text": self.text,
            "prompt_tokens": self.prompt_tokens,
            "completion_tokens": self.completion_tokens,
            "model": self.model,
            "estimated": self.estimated,
        }

    @classmethod
    def from_dict(cls, d: dict) -> VLMResponse:
        return cls(
            text=str(d["text"]),
            prompt_tokens=int(d.get("prompt_tokens", 0)),
            completion_tokens=int(d.get("completion_tokens", 0)),
            model=str(d.get("model", "")),
            estimated=bool(d.get("estimated", False)),
        )


@runtime_checkable
class VLMBackend(Protocol):
    """Anything that answers chat messages."""

    def complete(self, messages: list[Message], *, purpose: str, schema: dict | None = None) -> VLMResponse:
        """Answer ``messages``. ``purpose`` names the caller ("constraint_generator", "monitor_coder", ...).
        ``schema``: the JSON schema the answer must follow, for servers with structured outputs (a backend may
        ignore it: callers parse and validate the text either way).

        Raises:
            VLMConfigError: the backend is misconfigured (missing key, bad URL, unknown model).
            VLMRequestError: the server refuses the request (no images, context too small, ...), not retried.
            VLMTimeoutError: no answer within the timeout.
            VLMError: the server cannot be reached or keeps failing after bounded retries.
        """
        ...


@dataclass
class VLMBackendConfig(Choice):
    """Base of the VLM backend configs."""


STRUCTURED_MODES = ("auto", "json_schema", "json_object", "off")


@VLMBackendConfig.register("openai")
@dataclass
class OpenAIBackendConfig(VLMBackendConfig):
    """An OpenAI-compatible chat-completions server.

    Attributes:
        model: model name ("gpt-4o", or whatever a local server serves).
        base_url: server base URL ending in ``/v1``; None uses the SDK default (api.openai.com).
        api_key_env: environment variable holding the key; ``"none"`` for a local server that needs none.
        timeout_s: seconds a request may take before it is given up (and closed, so the server can stop).
            A CPU server answering a long prompt needs minutes: raise it there.
        connect_timeout_s: seconds to connect.
        max_retries: retries after the first attempt on 429, 5xx and connection errors (never on 4xx, a
            timeout, a cut-off answer or a model that takes no images: the same request would fail again).
        backoff_base_s, backoff_max_s: exponential backoff ``base * 2**attempt`` capped at max;
            a server's ``Retry-After`` header wins when present (also capped).
        temperature, max_tokens: sampling settings (``max_tokens`` plus the prompt must fit the server's
            context).
        image_detail: "low", "high" or "auto" for image parts that do not carry their own (the planner sends its
            views at "low", the coder its annotated views at "low" when they fit in 512 x 512).
        images: send images (False for a text-only model: the prompts go without their images).
        structured: the answer format asked of the server: "auto" (the JSON schema as ``response_format``
            json_schema, falling back to json_object + schema and then to prompt-only JSON when the server
            refuses one), "json_schema", "json_object" or "off" (prompt-only JSON, repaired by re-asking).
        stream: stream the answer, so that a request given up on is closed at once (the server sees the client
            leave and stops generating) and a cut-off answer is seen.
    """

    model: str = "gpt-4o"
    base_url: str | None = None
    api_key_env: str = "OPENAI_API_KEY"
    timeout_s: float = 120.0
    connect_timeout_s: float = 10.0
    max_retries: int = 3
    backoff_base_s: float = 1.0
    backoff_max_s: float = 30.0
    temperature: float = 0.0
    max_tokens: int = 2048
    image_detail: str = "auto"
    images: bool = True
    structured: str = "auto"
    stream: bool = True

    def __post_init__(self) -> None:
        check_positive("openai", "timeout_s", self.timeout_s)
        check_positive("openai", "connect_timeout_s", self.connect_timeout_s)
        check_positive("openai", "max_retries", self.max_retries, allow_zero=True)
        check_positive("openai", "backoff_base_s", self.backoff_base_s, allow_zero=True)
        check_positive("openai", "max_tokens", self.max_tokens)
        if self.image_detail not in ("low", "high", "auto"):
            raise ConfigError(f"openai.image_detail must be low, high or auto, got {self.image_detail!r}")
        if self.structured not in STRUCTURED_MODES:
            raise ConfigError(f"openai.structured must be one of {', '.join(STRUCTURED_MODES)}, got "
                              f"{self.structured!r}")
        if not self.api_key_env:
            raise ConfigError("openai.api_key_env must name an environment variable (or be 'none')")


@VLMBackendConfig.register("kb")
@dataclass
class KBBackendConfig(VLMBackendConfig):
    """The offline knowledge base: a rule-based stand-in for a VLM (not a VLM).

    Attributes:
        fenced: wrap answers in Markdown code fences, as chat models usually do (exercises the parsers).
    """

    fenced: bool = True


@VLMBackendConfig.register("replay")
@dataclass
class ReplayBackendConfig(VLMBackendConfig):
    """Record/replay of another backend through a JSONL cassette.

    Attributes:
        cassette: path of the JSONL cassette.
        mode: "replay" (answers only from the cassette; a miss is an error), "record" (asks ``inner``
            and writes a fresh cassette) or "auto" (replays hits, records misses).
        inner: the recorded backend's config (needed for "record" and "auto").
    """

    cassette: str = ""
    mode: str = "replay"
    inner: VLMBackendConfig | None = None

    def __post_init__(self) -> None:
        if not self.cassette:
            raise ConfigError("replay.cassette must name a JSONL file")
        if self.mode not in ("replay", "record", "auto"):
            raise ConfigError(f"replay.mode must be replay, record or auto, got {self.mode!r}")
        if self.mode != "replay" and self.inner is None:
            raise ConfigError(f"replay.mode={self.mode!r} needs an inner backend to record from")


IMPLEMENTATIONS: dict[str, str] = {
    "openai": "code_as_monitor.vlm.openai_backend:OpenAIBackend",
    "kb": "code_as_monitor.vlm.kb:KBBackend",
    "replay": "code_as_monitor.vlm.replay:ReplayBackend",
}
"""Registered backend name -> ``"module:Class"`` built from the config (imported by name, on first use, so
this module imports none of them: no import circle, no optional dependency loaded for nothing)."""


def make_backend(config: VLMBackendConfig) -> VLMBackend:
    """Build the backend for ``config`` (its implementation is imported here, by name)."""
    return build_lazily(IMPLEMENTATIONS, config, "VLM backend")
