"""Chat messages for VLM backends: a role and a list of content parts (text and images).

Images stay as ``uint8 (H, W, 3)`` RGB arrays here; only a backend that talks to a server encodes
them (the ``openai`` backend sends PNG base64 data URLs). The ``kb`` and ``replay`` backends never
encode them, so offline runs pay nothing for images.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from code_as_monitor.core.errors import ConfigError

Role = Literal["system", "user", "assistant"]


@dataclass(frozen=True)
class TextPart:
    """A piece of text."""

    text: str


@dataclass(frozen=True)
class ImagePart:
    """An RGB image, ``uint8 (H, W, 3)``, with an optional label (the view name)."""

    rgb: np.ndarray
    label: str = ""

    def __post_init__(self) -> None:
        a = np.asarray(self.rgb)
        if a.ndim != 3 or a.shape[2] != 3 or a.dtype != np.uint8:
            raise ConfigError(f"image part {self.label!r}: expected uint8 (H, W, 3), got {a.dtype} {a.shape}")
        object.__setattr__(self, "rgb", np.ascontiguousarray(a))

    def digest(self) -> str:
        """sha256 of the shape and raw pixels: identifies the image independent of any encoder."""
        h = hashlib.sha256()
        h.update(repr(self.rgb.shape).encode())
        h.update(self.rgb.tobytes())
        return h.hexdigest()


ContentPart = TextPart | ImagePart


@dataclass
class Message:
    """One chat message.

    Attributes:
        role: "system", "user" or "assistant".
        content: ordered text and image parts.
    """

    role: Role
    content: list[ContentPart] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.role not in ("system", "user", "assistant"):
            raise ConfigError(f"message role must be system, user or assistant, got {self.role!r}")

    @classmethod
    def system(cls, text: str) -> Message:
        return cls("system", [TextPart(text)])

    @classmethod
    def user(cls, text: str, images: dict[str, np.ndarray] | None = None) -> Message:
        """A user message: ``text`` then each image preceded by a one-line label naming its view."""
        parts: list[ContentPart] = [TextPart(text)]
        for name, rgb in (images or {}).items():
            parts.append(TextPart(f"View '{name}':"))
            parts.append(ImagePart(rgb, label=name))
        return cls("user", parts)

    @classmethod
    def assistant(cls, text: str) -> Message:
        return cls("assistant", [TextPart(text)])

    @property
    def text(self) -> str:
        """The text parts joined by newlines (images left out)."""
        return "\n".join(p.text for p in self.content if isinstance(p, TextPart))

    @property
    def images(self) -> list[ImagePart]:
        return [p for p in self.content if isinstance(p, ImagePart)]

    def to_record(self) -> dict:
        """JSON-serialisable form with images replaced by their digests (for hashing and cassettes)."""
        parts: list[dict] = []
        for p in self.content:
            if isinstance(p, TextPart):
                parts.append({"type": "text", "text": p.text})
            else:
                parts.append({"type": "image", "label": p.label, "shape": list(p.rgb.shape), "sha256": p.digest()})
        return {"role": self.role, "content": parts}


def count_images(messages: list[Message]) -> int:
    """Number of image parts over all messages."""
    return sum(len(m.images) for m in messages)
