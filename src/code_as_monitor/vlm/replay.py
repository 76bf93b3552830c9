"""``replay``: record another backend's requests and responses to a JSONL cassette, replay them by hash.

A request is identified by the sha256 of its canonical JSON: the purpose, every message (images replaced
by the sha256 of their raw pixels, so replay does not depend on a PNG encoder) and the answer's JSON schema
when one is asked for. The same request asked several times is answered in recorded order (the last answer
repeats). A request that is not in the cassette raises :class:`~code_as_monitor.core.errors.ReplayMissError` naming its
hash, purpose and the start of its last user message.

Cassette line: ``{"hash", "purpose", "request": {"messages": [...]}, "response": {...}}``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from code_as_monitor.core.errors import ConfigError, ReplayMissError, VLMError
from code_as_monitor.vlm.backend import ReplayBackendConfig, VLMBackend, VLMResponse, make_backend
from code_as_monitor.vlm.messages import Message


def request_record(messages: list[Message], purpose: str, schema: dict | None = None) -> dict:
    """The canonical JSON-able form of a request (the answer schema only when there is one)."""
    rec: dict = {"purpose": purpose, "messages": [m.to_record() for m in messages]}
    if schema is not None:
        rec["schema"] = schema
    return rec


def request_hash(messages: list[Message], purpose: str, schema: dict | None = None) -> str:
    """sha256 hex digest of the canonical request."""
    rec = request_record(messages, purpose, schema)
    blob = json.dumps(rec, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def _describe(messages: list[Message]) -> str:
    user = next((m for m in reversed(messages) if m.role == "user"), None)
    text = " ".join((user.text if user else "").split())
    return text[:80] + ("..." if len(text) > 80 else "")


class ReplayBackend:
    """Record/replay wrapper (see the module docstring).

    Args:
        cassette: JSONL path, or a :class:`ReplayBackendConfig` (then ``mode`` and ``inner`` come from it, the
            inner backend built from its config).
        mode: "replay" (cassette only), "record" (ask ``inner``, write a fresh cassette) or "auto"
            (replay hits, record misses by appending).
        inner: the backend to record (required for "record" and "auto").
    """

    def __init__(self, cassette: str | Path | ReplayBackendConfig, mode: str = "replay",
                 inner: VLMBackend | None = None) -> None:
        if isinstance(cassette, ReplayBackendConfig):
            cfg = cassette
            cassette, mode = cfg.cassette, cfg.mode
            inner = make_backend(cfg.inner) if cfg.inner is not None else None
        if mode not in ("replay", "record", "auto"):
            raise ConfigError(f"replay mode must be replay, record or auto, got {mode!r}")
        if mode != "replay" and inner is None:
            raise ConfigError(f"replay mode {mode!r} needs an inner backend to record from")
        self.path = Path(cassette)
        self.mode = mode
        self.inner = inner
        self.entries: dict[str, list[VLMResponse]] = {}
        self.served: dict[str, int] = {}
        if mode == "record":
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_text("", encoding="utf-8")
        elif self.path.exists():
            self._load()
        elif mode == "replay":
            raise VLMError(f"replay cassette {self.path} does not exist")

    def _load(self) -> None:
        for n, line in enumerate(self.path.read_text(encoding="utf-8").splitlines(), start=1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
                self.entries.setdefault(rec["hash"], []).append(VLMResponse.from_dict(rec["response"]))
            except (json.JSONDecodeError, KeyError, TypeError) as exc:
                raise VLMError(f"replay cassette {self.path}, line {n}: not a cassette entry ({exc})") from None

    def complete(self, messages: list[Message], *, purpose: str, schema: dict | None = None) -> VLMResponse:
        h = request_hash(messages, purpose, schema)
        if self.mode != "record" and h in self.entries:
            answers = self.entries[h]
            i = self.served.get(h, 0)
            self.served[h] = i + 1
            return answers[min(i, len(answers) - 1)]
        if self.mode == "replay":
            raise ReplayMissError(
                f"replay cassette {self.path} has no entry for request {h[:16]} (purpose {purpose}, "
                f"last user message: {_describe(messages)!r})"
            )
        assert self.inner is not None
        resp = self.inner.complete(messages, purpose=purpose, schema=schema)
        rec = {"hash": h, "purpose": purpose, "request": request_record(messages, purpose, schema),
               "response": resp.to_dict()}
        with self.path.open("a", encoding="utf-8") as fh:
            fh.write(json.dumps(rec, sort_keys=True) + "\n")
            fh.flush()
        self.entries.setdefault(h, []).append(resp)
        self.served[h] = self.served.get(h, 0) + 1
        return resp
