"""The offline token estimate: text by length, images by GPT-4o's published tile rule for size and detail."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.vlm.messages import ImagePart, Message, TextPart, fit_within, stack_views, view_parts
from code_as_monitor.vlm.usage import estimate_prompt_tokens, image_tokens


@pytest.mark.parametrize(("w", "h", "detail", "tokens"), [
    (1024, 1024, "high", 765),   # the pricing page's example: 768 x 768, 4 tiles
    (320, 240, "high", 255),     # one tile, not scaled up
    (320, 240, "auto", 255),     # auto is estimated as high
    (4096, 8192, "low", 85),
    (2048, 4096, "high", 1105),  # -> 1024 x 2048 -> 768 x 1536: 2 x 3 tiles
    (513, 100, "high", 425),     # two tiles across
])
def test_image_tokens(w, h, detail, tokens):
    assert image_tokens(w, h, detail) == tokens


def test_image_tokens_rejects_bad_values():
    with pytest.raises(ConfigError, match="'medium'"):
        image_tokens(10, 10, "medium")
    with pytest.raises(ConfigError, match="0x10"):
        image_tokens(0, 10)


def test_prompt_estimate_counts_each_image_at_its_own_detail():
    img = np.zeros((240, 320, 3), np.uint8)
    msg = Message("user", [TextPart("abcd" * 10), ImagePart(img, "a", detail="low"), ImagePart(img, "b")])
    assert estimate_prompt_tokens([msg]) == 4 + 10 + 85 + 255
    assert estimate_prompt_tokens([msg], detail="low") == 4 + 10 + 85 + 85
    assert estimate_prompt_tokens([msg], images=False) == 4 + 10
    with pytest.raises(ConfigError, match="detail"):
        ImagePart(img, "c", detail="huge")


def test_view_packing():
    a, b = np.zeros((240, 320, 3), np.uint8), np.ones((100, 200, 3), np.uint8)
    s = stack_views({"a": a, "b": b})
    assert s.shape == (340, 320, 3) and (s[240:, :200] == 1).all() and (s[240:, 200:] == 0).all()
    assert fit_within(np.zeros((1000, 500, 3), np.uint8)).shape == (512, 256, 3)
    assert fit_within(a) is a or np.shares_memory(fit_within(a), a)
    one = view_parts({"a": a})
    assert [type(p).__name__ for p in one] == ["TextPart", "ImagePart"] and one[1].detail == "low"
    big = {"a": np.zeros((480, 640, 3), np.uint8), "b": a}
    assert [p.detail for p in view_parts(big) if isinstance(p, ImagePart)] == ["high", "low"]
    [im] = [p for p in view_parts(big, downscale=True) if isinstance(p, ImagePart)]
    assert im.detail == "low" and max(im.rgb.shape[:2]) == 512 and im.label == "a+b"
    assert view_parts({}) == []
    with pytest.raises(ConfigError):
        stack_views({})
