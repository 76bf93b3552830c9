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


def _label_size(text: str, s: float) -> tuple[int, int, int]:
    """(width, height, baseline) in pixels of a label at scale ``s``."""
    (w, h), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.55 * s, max(1, round(1.5 * s)))
    return w, h, base


def _label(img: np.ndarray, text: str, org: tuple[int, int], color: tuple[int, int, int], s: float,
           alpha: float = 1.0) -> tuple[int, int, int, int]:
    """Draw ``text`` on a dark backing with its baseline-left corner near ``org`` (kept inside the image);
    ``alpha`` < 1 draws it faded into the picture. Returns the backing box (x0, y0, x1, y1)."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    fs = 0.55 * s
    th = max(1, round(1.5 * s))
    w, h, base = _label_size(text, s)
    x, y = org
    x = int(np.clip(x, 2, max(2, img.shape[1] - w - 4)))
    y = int(np.clip(y, h + 4, max(h + 4, img.shape[0] - base - 2)))
    box = (x - 2, y - h - 3, x + w + 2, y + base + 1)
    target = img if alpha >= 1.0 else img.copy()
    cv2.rectangle(target, box[:2], box[2:], (20, 20, 20), -1)
    cv2.putText(target, text, (x, y), font, fs, tuple(int(c) for c in color), th, cv2.LINE_AA)
    if alpha < 1.0:
        x0, y0 = max(0, box[0]), max(0, box[1])
        x1, y1 = min(img.shape[1], box[2] + 1), min(img.shape[0], box[3] + 1)
        img[y0:y1, x0:x1] = cv2.addWeighted(target[y0:y1, x0:x1], alpha, img[y0:y1, x0:x1], 1 - alpha, 0)
    return box


def place_labels(anchors: list[tuple[int, int]], sizes: list[tuple[int, int, int]], shape: tuple[int, ...],
                 r: int) -> list[tuple[int, int]]:
    """Baseline-left origins for labels of ``sizes`` (w, h, baseline) next to ``anchors`` (u, v pixels),
    chosen greedily so that no two backings overlap where the image leaves room.

    Each label tries the four corners around its anchor at one, two and three marker radii ``r``
    (up-right first, as a single label is drawn) and takes the first spot inside the image that
    overlaps no label placed before it; failing that, the spot with the least overlap.
    """
    placed = np.zeros((len(anchors), 4), dtype=np.int64)  # backings (x0, y0, x1, y1) of the labels placed so far
    out: list[tuple[int, int]] = []
    H, W = shape[0], shape[1]
    for i, ((u, v), (w, h, base)) in enumerate(zip(anchors, sizes)):
        best, best_cost = None, None
        xmax, ymin, ymax = max(2, W - w - 4), h + 4, max(h + 4, H - base - 2)
        prev = placed[:i]
        for k in (1, 2, 3):
            d = k * r + 2
            for dx, dy in ((d, -d), (d, d + h), (-d - w, -d), (-d - w, d + h)):
                x = min(max(int(u + dx), 2), xmax)
                y = min(max(int(v + dy), ymin), ymax)
                box = (x - 2, y - h - 3, x + w + 2, y + base + 1)
                ow = np.minimum(prev[:, 2], box[2]) - np.maximum(prev[:, 0], box[0])
                oh = np.minimum(prev[:, 3], box[3]) - np.maximum(prev[:, 1], box[1])
                cost = int((np.maximum(ow, 0) * np.maximum(oh, 0)).sum())
                if best_cost is None or cost < best_cost:
                    best, best_cost = (x, y, box), cost
                if cost == 0:
                    break
            if best_cost == 0:
                break
        assert best is not None
        out.append((best[0], best[1]))
        placed[i] = best[2]
    return out


def draw_elements(
    rgb: np.ndarray,
    camera: CameraModel,
    elements: Iterable[Element],
    stale: dict[int, np.ndarray] | None = None,
    alpha: float = 0.35,
) -> np.ndarray:
    """Return a copy of ``rgb`` (H, W, 3) uint8 with ``elements`` (world frame) drawn through ``camera``.

    Args:
        stale: element id -> (k,) bool; stale points are drawn hollow, and the label of an element
            whose points are all stale (hidden, e.g. under the arm) is drawn faded.
        alpha: opacity of surface fills.

    Labels are placed so that they do not cover each other (:func:`place_labels`).
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
    labels: list[tuple[str, tuple[int, int], tuple[int, int, int], bool]] = []
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
        hidden = st is not None and len(st) > 0 and bool(np.all(st))
        labels.append((str(el.id), (int(anchor[0]), int(anchor[1])), col, hidden))
    origins = place_labels([a for _, a, _, _ in labels], [_label_size(t, s) for t, _, _, _ in labels], img.shape, r)
    for (text, _, col, hidden), org in zip(labels, origins):
        _label(img, text, org, col, s, alpha=0.4 if hidden else 1.0)
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
