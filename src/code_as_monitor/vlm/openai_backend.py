"""``openai``: any OpenAI-compatible chat-completions server through the ``openai`` SDK.

GPT-4o, and local servers such as vLLM, Ollama or llama.cpp (``base_url`` ending in ``/v1``). What it does
for a real server (see :class:`~code_as_monitor.vlm.backend.OpenAIBackendConfig` for the settings):

- structured outputs: a caller's JSON schema goes as ``response_format`` (json_schema; then json_object with
  the schema, as llama-cpp-python takes it; then none) and a format the server refuses is not asked again;
- streaming with a deadline: a request is given up after ``timeout_s`` and its stream closed, so the server
  sees the client leave and stops generating instead of queueing the next request behind it; an answer cut
  off at ``max_tokens`` (finish_reason "length") is an error naming the fix, not a truncated answer;
- errors named for what they are (:mod:`.openai_errors`): a model that takes no images, a context too small,
  a rejected key or an unknown model are raised at once with the fix; only 429, 5xx and connection errors are
  retried, a bounded number of times with exponential backoff honouring ``Retry-After``;
- ``images=False`` sends the prompts without their images (text-only models);
- token usage from the server (streamed usage where the server sends it), else estimated and marked so.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from code_as_monitor.core.errors import VLMContextError, VLMError, VLMRequestError, VLMTimeoutError
from code_as_monitor.vlm.backend import OpenAIBackendConfig, VLMResponse
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.openai_errors import classify, context_fix, is_format_refusal
from code_as_monitor.vlm.openai_wire import NO_KEY, png_data_url, resolve_api_key, response_format, to_openai_messages
from code_as_monitor.vlm.usage import estimate_prompt_tokens, estimate_tokens

log = logging.getLogger(__name__)

__all__ = ["NO_KEY", "OpenAIBackend", "png_data_url", "resolve_api_key", "to_openai_messages"]

FORMATS = {"auto": ("json_schema", "json_object", "off"), "json_schema": ("json_schema",),
           "json_object": ("json_object",), "off": ("off",)}


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


def _message(exc: Exception) -> str:
    body = getattr(exc, "body", None)
    if isinstance(body, dict):
        err = body.get("error", body)
        if isinstance(err, dict) and err.get("message"):
            return str(err["message"])
        if isinstance(err, str):
            return err
    return str(getattr(exc, "message", None) or exc)


class _Answer:
    def __init__(self) -> None:
        self.parts: list[str] = []
        self.finish = ""
        self.model = ""
        self.usage: Any = None


class OpenAIBackend:
    """Chat completions against an OpenAI-compatible server (see the module docstring)."""

    def __init__(self, config: OpenAIBackendConfig | None = None) -> None:
        import openai

        self.config = config or OpenAIBackendConfig()
        self._openai = openai
        self._timeout = openai.Timeout(self.config.timeout_s, connect=self.config.connect_timeout_s)
        self.client = openai.OpenAI(
            api_key=resolve_api_key(self.config.api_key_env),
            base_url=self.config.base_url,
            timeout=self._timeout,
            max_retries=0,
        )
        self.where = f"{self.config.model} at {self.config.base_url or 'api.openai.com'}"
        self.formats = list(FORMATS[self.config.structured])
        """Structured-output formats still to try, best first (a refused one is dropped for the session)."""
        self.stream_usage = True
        """Ask for usage in the stream (dropped when a server refuses ``stream_options``)."""

    def _delay(self, attempt: int, exc: Exception | None) -> float:
        """Seconds before retry ``attempt + 1``: the server's Retry-After, else exponential, both capped."""
        ra = _retry_after(exc) if exc is not None else None
        base = self.config.backoff_base_s * (2**attempt)
        return min(self.config.backoff_max_s, ra if ra is not None else base)

    def complete(self, messages: list[Message], *, purpose: str, schema: dict | None = None) -> VLMResponse:
        openai = self._openai
        payload = to_openai_messages(messages, self.config.image_detail, self.config.images)
        attempts = 1 + self.config.max_retries
        last, attempt = "", 0
        while attempt < attempts:
            fmt = response_format(schema, self.formats[0])
            try:
                answer = self._ask(payload, fmt)
            except openai.APITimeoutError:
                raise VLMTimeoutError(
                    f"{self.where}: no answer within {self.config.timeout_s:g} s (the request was closed); a slow "
                    f"(CPU) server needs a longer --timeout, or a smaller --max-tokens") from None
            except openai.APIConnectionError as exc:
                last, retry_exc = f"cannot connect to the server ({exc.__cause__ or exc})", None
            except openai.APIStatusError as exc:
                text = _message(exc)
                if "stream_options" in text and self.stream_usage:
                    self.stream_usage = False  # an older server: no usage in the stream
                    continue
                if fmt is not None and is_format_refusal(exc.status_code, text):
                    if len(self.formats) > 1:
                        log.info("%s: %s refused (%s); trying %s", self.where, self.formats[0], text, self.formats[1])
                        self.formats.pop(0)
                        continue
                    raise VLMRequestError(
                        f"{self.where}: the server refuses structured output {self.formats[0]} (HTTP "
                        f"{exc.status_code}: {text[:200]}); use --structured auto or off") from None
                err = classify(exc.status_code, text, self.where, self.config.api_key_env, self.config.max_tokens)
                if err is not None:
                    raise err from None
                last, retry_exc = f"HTTP {exc.status_code}: {' '.join(text.split())[:200]}", exc
            else:
                return self._response(answer, messages)
            attempt += 1
            if attempt < attempts:
                delay = self._delay(attempt - 1, retry_exc)
                log.info("%s (%s): %s; retry %d/%d in %.2f s", self.where, purpose, last, attempt,
                         self.config.max_retries, delay)
                time.sleep(delay)
        raise VLMError(f"{self.where}: gave up after {attempts} attempt(s): {last}")

    def _ask(self, payload: list[dict[str, Any]], fmt: dict[str, Any] | None) -> _Answer:
        """One request; streamed requests are closed when the deadline passes or the answer ends."""
        kwargs: dict[str, Any] = {"model": self.config.model, "messages": payload,
                                  "temperature": self.config.temperature, "max_tokens": self.config.max_tokens,
                                  "timeout": self._timeout}
        if fmt is not None:
            kwargs["response_format"] = fmt
        answer = _Answer()
        if not self.config.stream:
            resp = self.client.chat.completions.create(**kwargs)
            try:
                choice = resp.choices[0]
                answer.parts, answer.finish = [choice.message.content or ""], str(choice.finish_reason or "")
            except (AttributeError, IndexError, TypeError):
                raise VLMError(f"{self.where}: malformed response without choices[0].message") from None
            answer.model, answer.usage = str(getattr(resp, "model", "") or ""), getattr(resp, "usage", None)
            return answer
        if self.stream_usage:
            kwargs["stream_options"] = {"include_usage": True}
        deadline = time.monotonic() + self.config.timeout_s
        stream = self.client.chat.completions.create(stream=True, **kwargs)
        try:
            for chunk in stream:
                answer.model = answer.model or str(getattr(chunk, "model", "") or "")
                if getattr(chunk, "usage", None) is not None:
                    answer.usage = chunk.usage
                for choice in getattr(chunk, "choices", None) or []:
                    delta = getattr(choice, "delta", None)
                    if delta is not None and getattr(delta, "content", None):
                        answer.parts.append(delta.content)
                    if getattr(choice, "finish_reason", None):
                        answer.finish = str(choice.finish_reason)
                if time.monotonic() > deadline:
                    raise self._openai.APITimeoutError(request=stream.response.request)
        finally:
            stream.close()  # the server sees the client leave and stops generating
        return answer

    def _response(self, answer: _Answer, messages: list[Message]) -> VLMResponse:
        text = "".join(answer.parts)
        if answer.finish == "length":
            raise VLMContextError(
                f"{self.where}: the answer was cut off at max_tokens={self.config.max_tokens} (finish_reason "
                f"length, {len(text)} characters); raise --max-tokens; if the server's context is the limit, "
                f"{context_fix(self.config.max_tokens)}")
        model = answer.model or self.config.model
        usage = answer.usage
        if usage is not None and getattr(usage, "prompt_tokens", None) is not None:
            return VLMResponse(text, int(usage.prompt_tokens), int(usage.completion_tokens or 0), model)
        prompt = estimate_prompt_tokens(messages, self.config.image_detail, self.config.images)
        return VLMResponse(text, prompt, estimate_tokens(text), model, estimated=True)
