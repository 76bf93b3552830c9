"""HTTP client for a served (constraint-aware) segmentation model. We ship no model: this is a client.

Wire format (version 1), JSON over HTTP, one request per view and element::

    POST <url>            Content-Type: application/json
    {
      "version": 1,
      "image": {"format": "png", "data": "<base64 PNG, RGB 8-bit, H x W>"},
      "depth": {"format": "png16", "unit": "mm", "data": "<base64 16-bit PNG>"},   # only with send_depth
      "width": W, "height": H,
      "camera": {"name": ..., "width": ..., "height": ..., "K": [[...]], "T_world_cam": [[...]]},
      "object": "red_block", "part": "top",          # part "" = the whole object
      "kind": "surface",                              # the kind the planner asked for
      "constraint": "the red block's top must stay level"
    }

    200 OK
    {
      "found": true,                                  # false: not visible -> empty masks
      "instance_mask": MASK,                          # the whole object
      "part_mask": MASK | null,                       # null: same as instance_mask
      "kind": "surface",                              # optional: the model's element kind
      "score": 0.93                                   # optional, [0, 1]
    }

    MASK = {"format": "rle", "size": [H, W], "counts": [c0, c1, ...]}
           run lengths over the row-major (C-order) pixels, alternating false / true and starting
           with a (possibly empty) false run; the counts sum to H * W;
         | {"format": "png", "data": "<base64 PNG, 1 channel, nonzero = in the mask>"}

    Errors: any non-200 status. A JSON body ``{"error": "..."}`` is quoted in the exception; a server
    should answer 404 naming an object it does not know.

Every failure (unreachable server, timeout, non-200 status, malformed answer, wrong mask size) is
raised as :class:`PerceptionError` with a one-line message naming the URL.
"""

from __future__ import annotations

import base64
import json
import urllib.error
import urllib.request
from typing import Any

import cv2
import numpy as np

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ElementError, PerceptionError
from code_as_monitor.core.observation import View
from code_as_monitor.perception.segmenters.base import HttpSegmenterConfig, Segmenter, SegmentResult

WIRE_VERSION = 1


# --- mask codecs (shared by clients and test servers) --------------------------------------------
def encode_rle(mask: np.ndarray) -> dict[str, Any]:
    """(H, W) bool -> ``{"format": "rle", "size": [H, W], "counts": [...]}`` (row-major, false first)."""
    flat = np.asarray(mask, dtype=bool).ravel()
    change = np.flatnonzero(flat[1:] != flat[:-1]) + 1
    bounds = np.concatenate([[0], change, [flat.size]])
    counts = np.diff(bounds).tolist()
    if flat.size and flat[0]:
        counts = [0, *counts]
    return {"format": "rle", "size": [int(mask.shape[0]), int(mask.shape[1])], "counts": counts}


def decode_mask(obj: Any, shape: tuple[int, int]) -> np.ndarray:
    """Decode a wire MASK to (H, W) bool of ``shape``; raises ValueError when malformed."""
    if not isinstance(obj, dict):
        raise ValueError(f"mask must be an object, got {type(obj).__name__}")
    fmt = obj.get("format")
    if fmt == "rle":
        size = tuple(int(x) for x in obj.get("size", ()))
        if size != shape:
            raise ValueError(f"rle mask size {list(size)} != image size {list(shape)}")
        counts = np.asarray(obj.get("counts", []), dtype=np.int64)
        if counts.ndim != 1 or (counts < 0).any() or counts.sum() != shape[0] * shape[1]:
            raise ValueError(f"rle counts must be non-negative and sum to {shape[0] * shape[1]}")
        values = np.arange(len(counts)) % 2 == 1
        return np.repeat(values, counts).reshape(shape)
    if fmt == "png":
        buf = np.frombuffer(base64.b64decode(obj.get("data", ""), validate=True), dtype=np.uint8)
        img = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
        if img is None:
            raise ValueError("png mask does not decode")
        if img.ndim == 3:
            img = img[..., 0]
        if img.shape != shape:
            raise ValueError(f"png mask size {list(img.shape)} != image size {list(shape)}")
        return img != 0
    raise ValueError(f"unknown mask format {fmt!r} (expected 'rle' or 'png')")


def encode_png(image: np.ndarray) -> str:
    """Base64 PNG of an (H, W, 3) RGB uint8, (H, W) uint8 or (H, W) uint16 image."""
    img = image[..., ::-1] if image.ndim == 3 else image  # OpenCV writes BGR
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(img))
    if not ok:
        raise PerceptionError("could not PNG-encode the image")
    return base64.b64encode(buf.tobytes()).decode("ascii")


def decode_png_rgb(data: str) -> np.ndarray:
    """Inverse of :func:`encode_png` for an RGB image: (H, W, 3) uint8."""
    img = cv2.imdecode(np.frombuffer(base64.b64decode(data), dtype=np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError("image does not decode")
    return img[..., ::-1].copy()


# --- client -------------------------------------------------------------------------------------
class HttpSegmenter(Segmenter):
    """Client of a segmentation server speaking the wire format above."""

    def __init__(self, config: HttpSegmenterConfig | None = None) -> None:
        self.config = config or HttpSegmenterConfig()

    def request_body(self, view: View, spec: ElementSpec, constraint_text: str = "") -> dict[str, Any]:
        """The JSON request for one view and element spec."""
        h, w = view.depth.shape
        body: dict[str, Any] = {
            "version": WIRE_VERSION,
            "image": {"format": "png", "data": encode_png(view.rgb)},
            "width": w,
            "height": h,
            "camera": view.camera.to_dict(),
            "object": spec.obj,
            "part": spec.part,
            "kind": spec.kind.value,
            "constraint": constraint_text,
        }
        if self.config.send_depth:
            d = np.nan_to_num(view.depth.astype(np.float64), nan=0.0, posinf=0.0, neginf=0.0)
            mm = np.clip(np.rint(d * 1000.0), 0, 65535).astype(np.uint16)
            body["depth"] = {"format": "png16", "unit": "mm", "data": encode_png(mm)}
        return body

    def segment(self, view: View, spec: ElementSpec, constraint_text: str = "") -> SegmentResult:
        url = self.config.url
        shape = view.depth.shape
        answer = self._post(self.request_body(view, spec, constraint_text))
        if not isinstance(answer, dict):
            raise PerceptionError(f"segmentation server {url}: answer is not a JSON object")
        try:
            kind = ElementKind.parse(answer.get("kind") or spec.kind)
        except ElementError as exc:
            raise PerceptionError(f"segmentation server {url}: {exc}") from None
        if not answer.get("found", True):
            return SegmentResult.nothing(shape, kind)
        try:
            instance = decode_mask(answer.get("instance_mask"), shape)
            pm = answer.get("part_mask")
            part = instance.copy() if pm is None else decode_mask(pm, shape)
            score = float(answer.get("score", 1.0 if instance.any() else 0.0))
        except (ValueError, TypeError) as exc:
            raise PerceptionError(f"segmentation server {url}: malformed answer: {_one_line(str(exc))}") from None
        return SegmentResult(instance, part, kind, min(1.0, max(0.0, score)))

    def _post(self, body: dict[str, Any]) -> Any:
        url, timeout = self.config.url, self.config.timeout_s
        req = urllib.request.Request(
            url, data=json.dumps(body).encode("utf-8"), method="POST",
            headers={"Content-Type": "application/json", "Accept": "application/json"},
        )
        try:
            with urllib.request.urlopen(req, timeout=timeout) as resp:
                raw = resp.read()
        except urllib.error.HTTPError as exc:
            raise PerceptionError(
                f"segmentation server {url} answered HTTP {exc.code}: {_error_text(exc)}"
            ) from None
        except urllib.error.URLError as exc:
            if isinstance(exc.reason, TimeoutError):
                raise PerceptionError(f"segmentation server {url} did not answer within {timeout:g} s") from None
            raise PerceptionError(f"cannot reach segmentation server {url}: {_one_line(str(exc.reason))}") from None
        except TimeoutError:
            raise PerceptionError(f"segmentation server {url} did not answer within {timeout:g} s") from None
        except OSError as exc:
            raise PerceptionError(f"segmentation server {url}: {_one_line(str(exc))}") from None
        try:
            return json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise PerceptionError(f"segmentation server {url}: answer is not JSON") from None


def _error_text(exc: urllib.error.HTTPError) -> str:
    try:
        raw = exc.read().decode("utf-8", "replace")
    except OSError:
        raw = ""
    try:
        obj = json.loads(raw)
        text = str(obj.get("error", raw)) if isinstance(obj, dict) else raw
    except json.JSONDecodeError:
        text = raw
    return _one_line(text or exc.reason or "no details")


def _one_line(text: str, limit: int = 200) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[: limit - 3] + "..."
