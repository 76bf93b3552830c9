"""The pixel vocabulary the ``vqa-standin`` rules share: colour ranges, colour masks, blobs, the yes/no answer.

A stand-in, not a VLM (see :mod:`code_as_monitor.baselines.vqa_standin`). Every rule module
(:mod:`~code_as_monitor.baselines.vqa_standin_gripper`, :mod:`~code_as_monitor.baselines.vqa_standin_drawer`,
:mod:`~code_as_monitor.baselines.vqa_standin_tea`,
:mod:`~code_as_monitor.baselines.vqa_standin_rlbench`) and the answerer itself import this module; it imports none of
them, so the rules and the answerer that dispatches to them form no import circle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# OpenCV HSV (H in 0..179): (h_lo, h_hi, s_min, v_min[, s_max]); red wraps around 0. The flat-shaded
# renderer keeps H and S of a face constant and changes only V, so the ranges are narrow in H.
HSV_RANGES: dict[str, list[tuple[int, ...]]] = {
    "red": [(0, 4, 120, 60), (172, 179, 120, 60)],
    "green": [(45, 85, 100, 50)],
    "blue": [(100, 130, 120, 50)],
    "brick": [(3, 10, 120, 50)],  # sweep-half blocks
    "yellow": [(20, 32, 100, 120)],  # sweep-half zone
    "orange": [(10, 18, 120, 100)],  # rope beads; the pen holder's rim
    "cream": [(20, 32, 50, 100, 140)],  # the book's spine (pale yellow: S ~95, under "yellow")
    "teal": [(84, 96, 150, 60)],  # the bookshelf's slot rim
    "wood": [(12, 17, 120, 50, 190)],  # the bookshelf's body (S ~155, under the holder rim's ~230)
    "brown": [(12, 17, 110, 40, 190)],  # the drawer cabinet's body (H ~14, S ~145, V 80..140)
    "brass": [(19, 26, 150, 60)],  # the drawer's handle bar (H ~22, S ~210; its shaded face V ~130)
    "pothandle": [(12, 17, 160, 40, 210)],  # the teapot's handle fin (S ~185, V 60..110; the tea's S ~230)
    "dirt": [(13, 17, 160, 20, 182)],  # sweep-to-dustpan's dirt (H ~15, S ~170; the pan's orange S ~215)
    "pan": [(11, 17, 205, 60)],  # the dustpan's floor and walls (H 12..15, S ~215)
    "white": [(0, 179, 0, 170, 30)],  # the bulb's neck (S ~6, V ~235)
}
# Also used by the gripper tasks: "blue" (pen body), "yellow" (pen tip), "green" (holder body), "red"
# (book cover); by the drawer: "blue" (the drawer's front plate and tray).

@dataclass(frozen=True)
class VQAAnswer:
    """A yes/no answer with a one-line reason (the reason becomes re-planning feedback on "no")."""

    yes: bool
    reason: str


@dataclass(frozen=True)
class Blob:
    """One colour component in image pixels: centre (u, v), bounding box, area."""

    u: float
    v: float
    left: int
    top: int
    right: int
    bottom: int
    area: int

    @property
    def width(self) -> int:
        return self.right - self.left + 1


def color_mask(rgb: np.ndarray, color: str) -> np.ndarray:
    """(H, W) bool mask of pixels of colour ``color`` (a key of :data:`HSV_RANGES`)."""
    import cv2

    hsv = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2HSV)
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    out = np.zeros(h.shape, dtype=bool)
    for h0, h1, s0, v0, *s1 in HSV_RANGES[color]:
        out |= (h >= h0) & (h <= h1) & (s >= s0) & (v >= v0) & (s <= (s1[0] if s1 else 255))
    return out


def blobs(mask: np.ndarray, min_area: int = 4) -> list[Blob]:
    """Connected components of ``mask`` with at least ``min_area`` pixels, largest first."""
    import cv2

    n, _, stats, cents = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    out = []
    for i in range(1, n):
        x, y, w, h, a = (int(s) for s in stats[i])
        if a >= min_area:
            out.append(Blob(float(cents[i][0]), float(cents[i][1]), x, y, x + w - 1, y + h - 1, a))
    return sorted(out, key=lambda b: -b.area)


__all__ = ["HSV_RANGES", "Blob", "VQAAnswer", "blobs", "color_mask"]
