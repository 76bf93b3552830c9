"""Call and token accounting per subgoal and per episode.

The paper's cost argument is that the VLM is asked once per subgoal for constraints and once for code
(plus bounded re-asks), not at every frame. :class:`UsageMeter` makes that measurable: every call is
recorded with the subgoal it belongs to and its purpose ("constraint_generator", "monitor_coder", or
a baseline's "vqa"), and summaries give calls and prompt/completion tokens per subgoal and per episode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.vlm.backend import VLMResponse
from code_as_monitor.vlm.messages import DETAILS, Message

LOW_DETAIL_TOKENS = 85
"""An image sent at detail "low" (the model sees it within 512 x 512): a fixed 85 tokens."""
TILE_TOKENS = 170
"""Each 512-px tile of an image sent at detail "high", on top of :data:`LOW_DETAIL_TOKENS`."""
TILE_PX = 512


def image_tokens(width: int, height: int, detail: str = "auto") -> int:
    """Estimated prompt tokens of one ``width x height`` image sent at ``detail`` (GPT-4o's published tile rule).

    ``low``: 85. ``high``: the image is scaled down (never up) to fit 2048 x 2048, then down so that its
    shorter side is at most 768 px; each 512-px tile of the result costs 170, plus 85 (a 1024 x 1024 image:
    765; 320 x 240: one tile, 255). ``auto`` lets the server choose; it is estimated as ``high`` (an upper
    bound). OpenAI's wording ("scaled such that the shortest side is 768px") can also be read as scaling
    small images up, which would cost 765 for 320 x 240; the calculators that follow its pricing page, and
    this estimate, do not scale up.
    """
    if detail not in DETAILS:
        raise ConfigError(f"image detail must be one of {', '.join(DETAILS)}, got {detail!r}")
    if width <= 0 or height <= 0:
        raise ConfigError(f"image size must be positive, got {width}x{height}")
    if detail == "low":
        return LOW_DETAIL_TOKENS
    w, h = float(width), float(height)
    s = min(1.0, 2048.0 / max(w, h))
    w, h = w * s, h * s
    s = min(1.0, 768.0 / min(w, h))
    w, h = w * s, h * s
    tiles = math.ceil(round(w, 6) / TILE_PX) * math.ceil(round(h, 6) / TILE_PX)
    return LOW_DETAIL_TOKENS + TILE_TOKENS * tiles


def estimate_tokens(text: str) -> int:
    """Rough token count of ``text`` (about 4 characters per token)."""
    return math.ceil(len(text) / 4.0) if text else 0


def estimate_prompt_tokens(messages: list[Message], detail: str = "auto", images: bool = True) -> int:
    """Rough prompt-token count of ``messages``: 4 per message, text by length, each image by
    :func:`image_tokens` for its size and detail (its own, else ``detail``; none when ``images`` is False)."""
    total = 0
    for m in messages:
        total += 4 + estimate_tokens(m.text)
        if images:
            for im in m.images:
                h, w = im.rgb.shape[:2]
                total += image_tokens(w, h, im.detail or detail)
    return total


@dataclass(frozen=True)
class UsageRecord:
    """One backend call."""

    subgoal: int
    purpose: str
    prompt_tokens: int
    completion_tokens: int
    model: str
    latency_s: float
    estimated: bool

    def to_dict(self) -> dict[str, Any]:
        return {
            "subgoal": self.subgoal,
            "purpose": self.purpose,
            "prompt_tokens": self.prompt_tokens,
            "completion_tokens": self.completion_tokens,
            "model": self.model,
            "latency_s": round(self.latency_s, 6),
            "estimated": self.estimated,
        }


def _sum(records: list[UsageRecord]) -> dict[str, Any]:
    by_purpose: dict[str, int] = {}
    tokens_by_purpose: dict[str, int] = {}
    for r in records:
        by_purpose[r.purpose] = by_purpose.get(r.purpose, 0) + 1
        tokens_by_purpose[r.purpose] = tokens_by_purpose.get(r.purpose, 0) + r.prompt_tokens + r.completion_tokens
    return {
        "calls": len(records),
        "prompt_tokens": sum(r.prompt_tokens for r in records),
        "completion_tokens": sum(r.completion_tokens for r in records),
        "total_tokens": sum(r.prompt_tokens + r.completion_tokens for r in records),
        "calls_by_purpose": dict(sorted(by_purpose.items())),
        "tokens_by_purpose": dict(sorted(tokens_by_purpose.items())),
        "latency_s": round(sum(r.latency_s for r in records), 6),
        "estimated": any(r.estimated for r in records),
    }


@dataclass
class UsageMeter:
    """Accumulates :class:`UsageRecord` for one episode.

    The constraint generator calls :meth:`start_subgoal` before asking for a new subgoal, so its own
    calls and the monitor coder's calls that follow are attributed to that subgoal. Calls made before
    any subgoal was started are attributed to subgoal 0.
    """

    records: list[UsageRecord] = field(default_factory=list)
    current_subgoal: int = -1

    def start_subgoal(self) -> int:
        """Open the next subgoal slot; returns its index (0, 1, ...)."""
        self.current_subgoal += 1
        return self.current_subgoal

    def record(self, purpose: str, response: VLMResponse, latency_s: float = 0.0) -> UsageRecord:
        """Count one call of ``purpose`` answered by ``response``."""
        rec = UsageRecord(
            subgoal=max(self.current_subgoal, 0),
            purpose=purpose,
            prompt_tokens=int(response.prompt_tokens),
            completion_tokens=int(response.completion_tokens),
            model=response.model,
            latency_s=float(latency_s),
            estimated=bool(response.estimated),
        )
        self.records.append(rec)
        return rec

    @property
    def calls(self) -> int:
        return len(self.records)

    def per_subgoal(self) -> list[dict[str, Any]]:
        """One summary per subgoal index that has calls, in order."""
        idx = sorted({r.subgoal for r in self.records})
        return [{"subgoal": i, **_sum([r for r in self.records if r.subgoal == i])} for i in idx]

    def episode(self) -> dict[str, Any]:
        """Totals over the episode, plus the number of subgoals and calls per subgoal."""
        out = _sum(self.records)
        n_sub = len({r.subgoal for r in self.records})
        out["subgoals"] = n_sub
        out["calls_per_subgoal"] = round(out["calls"] / n_sub, 3) if n_sub else 0.0
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"episode": self.episode(), "per_subgoal": self.per_subgoal()}
