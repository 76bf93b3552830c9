"""Anonymous detections for the depth tracker's small bodies: the segmenter's masks in each view lifted with
depth to centroids, with no record of which query produced which (see
:mod:`code_as_monitor.perception.trackers.depth_detect` for how they are associated).

Frames: world metres; depth (H, W) metres along the optical axis, 0 or NaN = no reading; rgb (H, W, 3) uint8.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.core.errors import CamError
from code_as_monitor.core.observation import Observation

log = logging.getLogger(__name__)


@dataclass
class ViewDetections:
    """One view's anonymous detections.

    Attributes:
        centroids: (m, 3) world metres, sorted by x, then y.
        truncated: (m,) bool, True where something nearer the camera borders the mask (partly occluded: its
            centroid is pulled towards the visible part).
        chroma: (m, 3) mean chromaticity (R, G, B) / (R + G + B) of each mask's pixels.
        eye: (3,) the camera's centre, world metres.
    """

    centroids: np.ndarray
    truncated: np.ndarray
    chroma: np.ndarray
    eye: np.ndarray


def detect(segmenter: object, obs: Observation, views: Sequence[str], specs: list[ElementSpec],
           min_pixels: int, max_extent: float) -> dict[str, ViewDetections]:
    """Anonymous detections per view name: the centroids of the masks the segmenter gives for ``specs`` in
    that view (the query that produced each is not kept).

    Points further than ``max_extent`` from a mask's median point (a mask bleeding onto the background) are
    left out of its centroid; a mask with fewer than ``min_pixels`` valid depth pixels is no detection;
    masks giving the same centroid (a segmenter answering two queries with one instance) count once. A mask
    is *truncated* when over a fifth of the valid pixels just outside it read nearer than its median depth
    by more than half ``max_extent`` (an occluder in front, not a neighbour beside it).
    """
    from code_as_monitor.geometry.backproject import LiftedView

    out: dict[str, ViewDetections] = {}
    if not specs:
        return out
    for name in views:
        view = obs.views[name]
        eye = np.asarray(view.camera.T_world_cam, dtype=np.float64)[:3, 3]
        try:
            lifted = LiftedView(view.depth, view.camera)
            results = segmenter.segment_many(view, specs)  # type: ignore[attr-defined]
        except CamError as exc:  # a view the segmenter cannot read (no seg image, bad size): no detections there
            log.warning("depth tracker: no detections in view %r: %s", name, exc)
            continue
        cents: list[np.ndarray] = []
        cut: list[bool] = []
        chroma: list[np.ndarray] = []
        rgb = np.asarray(view.rgb) if np.shape(view.rgb) == (*np.shape(view.depth), 3) else None
        for r in results:
            mask = getattr(r, "part_mask", None)
            box = _box(mask) if mask is not None else None
            if box is None:
                continue
            r0, r1, c0, c1 = box  # the work below is on the mask's bounding box, not the whole image
            crop = mask[r0:r1, c0:c1]
            P = lifted.points(crop, (r0, c0))
            if len(P) >= min_pixels:
                P = P[np.linalg.norm(P - np.median(P, axis=0), axis=1) <= max_extent]
            if len(P) < min_pixels:
                continue
            c = P.mean(axis=0)
            if not cents or float(np.min(np.linalg.norm(np.array(cents) - c, axis=1))) >= 1e-4:
                cents.append(c)
                cut.append(_truncated(mask, box, lifted.depth, lifted.valid, 0.5 * max_extent))
                col = rgb[r0:r1, c0:c1][crop].astype(np.float64).mean(axis=0) if rgb is not None else np.ones(3)
                chroma.append(col / max(float(col.sum()), 1e-9))
        C = np.array(cents).reshape(-1, 3)
        order = np.lexsort((C[:, 1], C[:, 0])) if len(C) else np.zeros(0, dtype=int)
        out[name] = ViewDetections(C[order], np.array(cut, dtype=bool)[order],
                                   np.array(chroma).reshape(-1, 3)[order], eye)
    return out


def _box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """``(first row, last row + 1, first column, last column + 1)`` of the set pixels of ``mask`` (H, W) bool;
    None when it has none."""
    rows = np.flatnonzero(mask.any(axis=1))
    if not len(rows):
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _truncated(mask: np.ndarray, box: tuple[int, int, int, int], depth: np.ndarray, valid: np.ndarray,
               nearer: float) -> bool:
    """Whether over a fifth of the valid pixels in a 2-pixel ring around ``mask`` (H, W; its set pixels lie in
    ``box``, see :func:`_box`) read more than ``nearer`` metres nearer than the mask's median depth."""
    import cv2

    r0, r1 = max(box[0] - 2, 0), min(box[1] + 2, mask.shape[0])
    c0, c1 = max(box[2] - 2, 0), min(box[3] + 2, mask.shape[1])
    m = mask[r0:r1, c0:c1].astype(np.uint8)
    ring = (cv2.dilate(m, np.ones((5, 5), np.uint8)) > 0) & (m == 0) & valid[r0:r1, c0:c1]
    inside = m.astype(bool) & valid[r0:r1, c0:c1]
    if not ring.any() or not inside.any():
        return False
    d = depth[r0:r1, c0:c1]
    return bool(np.mean(d[ring] < float(np.median(d[inside])) - nearer) > 0.2)
