"""Draw constraint elements as visual prompts: numbered, coloured points, lines and surfaces.

Points become filled dots, lines segments with dotted ends, surfaces translucent filled outlines; each
element carries its number (the id the monitor code refers to) in its colour, on a dark backing so it
stays legible on any background. Drawing is done with OpenCV on a copy of the RGB image.
"""

from __future__ import annotations

from collections.abc import Iterable

import cv2
import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import Element, ElementKind


def _scale(img: np.ndarray) -> float:
    return max(0.5, min(img.shape[0], img.shape[1]) / 480.0)


def _label(img: np.ndarray, text: str, org: tuple[int, int], color: tuple[int, int, int], s: float) -> None:
    font = cv2.FONT_HERSHEY_SIMPLEX
    fs = 0.55 * s
    th = max(1, round(1.5 * s))
    (w, h), base = cv2.getTextSize(text, font, fs, th)
    x, y = org
    x = int(np.clip(x, 0, img.shape[1] - w - 4))
    y = int(np.clip(y, h + 4, img.shape[0] - base - 2))
    cv2.rectangle(img, (x - 2, y - h - 3), (x + w + 2, y + base + 1), (20, 20, 20), -1)
    cv2.putText(img, text, (x, y), font, fs, tuple(int(c) for c in color), th, cv2.LINE_AA)


def draw_elements(
    rgb: np.ndarray,
    camera: CameraModel,
    elements: Iterable[Element],
    stale: dict[int, np.ndarray] | None = None,
    alpha: float = 0.35,
) -> np.ndarray:
    """Return a copy of ``rgb`` (H, W, 3) uint8 with ``elements`` (world frame) drawn through ``camera``.

    Args:
        stale: element id -> (k,) bool; stale points are drawn hollow.
        alpha: opacity of surface fills.
    """
    img = np.ascontiguousarray(rgb.copy())
    s = _scale(img)
    r = max(3, round(5 * s))
    projected: list[tuple[Element, np.ndarray]] = []
    for el in elements:
        uv, z = camera.project(el.points)
        if np.any(z <= 1e-6) or not np.all(np.isfinite(uv)):
            continue
        projected.append((el, np.round(uv).astype(np.int32)))
    # Surface fills first (blended), then outlines, lines, points and labels on top at full opacity.
    polys: dict[int, np.ndarray] = {}
    overlay = img.copy()
    for el, pts in projected:
        if el.kind is ElementKind.SURFACE:
            c = pts.mean(axis=0)
            order = np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))
            polys[el.id] = pts[order].reshape(-1, 1, 2)
            cv2.fillPoly(overlay, [polys[el.id]], tuple(int(v) for v in el.color))
    if polys:
        img = cv2.addWeighted(overlay, alpha, img, 1 - alpha, 0)
    labels: list[tuple[str, tuple[int, int], tuple[int, int, int]]] = []
    for el, pts in projected:
        col = tuple(int(c) for c in el.color)
        st = stale.get(el.id) if stale else None
        if el.id in polys:
            cv2.polylines(img, [polys[el.id]], True, col, max(1, round(2 * s)), cv2.LINE_AA)
        elif el.kind is ElementKind.LINE:
            cv2.line(img, tuple(pts[0]), tuple(pts[1]), col, max(2, round(3 * s)), cv2.LINE_AA)
        for i, p in enumerate(pts):
            hollow = st is not None and i < len(st) and bool(st[i])
            cv2.circle(img, tuple(p), r, col, 2 if hollow else -1, cv2.LINE_AA)
            if not hollow:
                cv2.circle(img, tuple(p), r, (255, 255, 255), 1, cv2.LINE_AA)
        anchor = pts.mean(axis=0).astype(int)
        labels.append((str(el.id), (int(anchor[0]) + r + 2, int(anchor[1]) - r - 2), col))
    for text, org, col in labels:
        _label(img, text, org, col, s)
    return img


def draw_banner(rgb: np.ndarray, text: str, color: tuple[int, int, int] = (200, 30, 30)) -> np.ndarray:
    """Return a copy of ``rgb`` with a full-width banner carrying ``text`` at the top (e.g. a violation)."""
    img = np.ascontiguousarray(rgb.copy())
    s = _scale(img)
    h = round(26 * s)
    cv2.rectangle(img, (0, 0), (img.shape[1], h), color, -1)
    font = cv2.FONT_HERSHEY_SIMPLEX
    fs = 0.5 * s
    max_chars = max(10, int(img.shape[1] / (10 * s)))
    cv2.putText(img, text[:max_chars], (6, h - round(8 * s)), font, fs, (255, 255, 255), 1, cv2.LINE_AA)
    return img


def draw_caption(rgb: np.ndarray, text: str) -> np.ndarray:
    """Return a copy of ``rgb`` with a small caption (view name, time) at the bottom-left."""
    img = np.ascontiguousarray(rgb.copy())
    s = _scale(img)
    _label(img, text, (4, img.shape[0] - 6), (255, 255, 255), s * 0.8)
    return img
