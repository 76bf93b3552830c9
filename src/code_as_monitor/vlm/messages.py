"""Chat messages for VLM backends: a role and a list of content parts (text and images).

Images stay as ``uint8 (H, W, 3)`` RGB arrays here; only a backend that talks to a server encodes
them (the ``openai`` backend sends PNG base64 data URLs). The ``kb`` and ``replay`` backends never
encode them, so offline runs pay nothing for images. An image may carry the detail it is to be sent at
("low": the model sees it within 512 x 512 for a fixed 85 tokens; "high": tiled; "auto": the server
chooses); without one the backend's default applies. :func:`lossless_detail` picks "low" for an image that
already fits in 512 x 512 (nothing is lost) and :func:`fit_within` scales an image down for a low-detail view;
:func:`view_parts` packs several views into one low-detail image when they fit (one image's tokens, not one per view).
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


DETAILS = ("low", "high", "auto")
LOW_DETAIL_PX = 512
"""At detail "low" the model sees an image within ``LOW_DETAIL_PX x LOW_DETAIL_PX``."""


@dataclass(frozen=True)
class ImagePart:
    """An RGB image, ``uint8 (H, W, 3)``, with an optional label (the view name) and the detail to send it at
    (None: the backend's default)."""

    rgb: np.ndarray
    label: str = ""
    detail: str | None = None

    def __post_init__(self) -> None:
        a = np.asarray(self.rgb)
        if a.ndim != 3 or a.shape[2] != 3 or a.dtype != np.uint8:
            raise ConfigError(f"image part {self.label!r}: expected uint8 (H, W, 3), got {a.dtype} {a.shape}")
        if self.detail is not None and self.detail not in DETAILS:
            raise ConfigError(f"image part {self.label!r}: detail must be one of {', '.join(DETAILS)}, "
                              f"got {self.detail!r}")
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
    def user(cls, text: str, images: dict[str, np.ndarray] | None = None, detail: str | None = None) -> Message:
        """A user message: ``text`` then each image preceded by a one-line label naming its view, sent at
        ``detail`` (None: the backend's default)."""
        parts: list[ContentPart] = [TextPart(text)]
        for name, rgb in (images or {}).items():
            parts.append(TextPart(f"View '{name}':"))
            parts.append(ImagePart(rgb, label=name, detail=detail))
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
                rec = {"type": "image", "label": p.label, "shape": list(p.rgb.shape), "sha256": p.digest()}
                if p.detail is not None:
                    rec["detail"] = p.detail
                parts.append(rec)
        return {"role": self.role, "content": parts}


def count_images(messages: list[Message]) -> int:
    """Number of image parts over all messages."""
    return sum(len(m.images) for m in messages)


def lossless_detail(rgb: np.ndarray) -> str:
    """"low" when ``rgb`` already fits in the low-detail view (512 x 512: nothing is lost), else "high"."""
    h, w = np.asarray(rgb).shape[:2]
    return "low" if max(h, w) <= LOW_DETAIL_PX else "high"


def fit_within(rgb: np.ndarray, max_side: int = LOW_DETAIL_PX) -> np.ndarray:
    """``rgb`` scaled down (area averaging, aspect kept) so that its longer side is at most ``max_side``
    pixels; returned unchanged when it already fits."""
    a = np.asarray(rgb)
    h, w = a.shape[:2]
    if max(h, w) <= max_side:
        return a
    import cv2

    s = max_side / float(max(h, w))
    size = (max(1, round(w * s)), max(1, round(h * s)))
    return np.ascontiguousarray(cv2.resize(a, size, interpolation=cv2.INTER_AREA))


def stack_views(images: dict[str, np.ndarray]) -> np.ndarray:
    """The views one above the other in their order, narrower ones padded on the right with black:
    ``uint8 (sum of heights, largest width, 3)``."""
    arrays = [np.asarray(a) for a in images.values()]
    if not arrays:
        raise ConfigError("stack_views needs at least one view")
    width = max(a.shape[1] for a in arrays)
    rows = [a if a.shape[1] == width else np.pad(a, ((0, 0), (0, width - a.shape[1]), (0, 0))) for a in arrays]
    return np.ascontiguousarray(np.concatenate(rows, axis=0))


def view_parts(images: dict[str, np.ndarray], downscale: bool = False) -> list[ContentPart]:
    """The views as the content parts of a user message, each image preceded by a line naming what it shows.

    Several views go as ONE image, stacked top to bottom (:func:`stack_views`), sent at detail "low", when the
    stack fits the low-detail view (512 x 512) as it is, or, with ``downscale``, once scaled down to fit: one
    image's tokens instead of one per view. Otherwise each view goes on its own: scaled down to fit 512 x 512
    with ``downscale``, and at the cheapest detail that keeps all its pixels (:func:`lossless_detail`). Without
    ``downscale`` no pixel is lost (annotated views: labels stay as legible as drawn).
    """
    if not images:
        return []
    names = list(images)
    if len(images) > 1:
        stacked = stack_views(images)
        if downscale:
            stacked = fit_within(stacked)
        if max(stacked.shape[:2]) <= LOW_DETAIL_PX:
            listed = ", ".join(f"'{n}'" for n in names)
            return [TextPart(f"Views {listed}, top to bottom, in one image:"),
                    ImagePart(stacked, label="+".join(names), detail="low")]
    parts: list[ContentPart] = []
    for name, rgb in images.items():
        im = fit_within(rgb) if downscale else np.asarray(rgb)
        parts += [TextPart(f"View '{name}':"), ImagePart(im, label=name, detail=lossless_detail(im))]
    return parts
