"""Classical colour + depth segmentation of coloured objects on a table (works on real images).

Per call (one view, one object):

1. colour: the object's colour is the first ``_``-separated token of its name found in the colour
   table (``"red_block"`` -> ``"red"``), or ``object_colors[name]``; an object without one raises
   :class:`PerceptionError`. Pixels inside any of the colour's HSV boxes are candidates.
2. table removal (when the view has depth): the dominant plane is fitted by RANSAC on a sample of
   the view's valid depth pixels lifted to 3-D (``geometry.backproject_pixels``) and oriented towards
   the camera; candidate pixels lifted to less than ``min_height`` above it are dropped (a red mark
   printed on the table is not a red block). Candidates without a depth reading are kept (colour is
   the only evidence). Objects listed in ``flat_objects`` (marked zones) skip this step.
3. cleanup: morphological opening then closing, then the largest connected component (every
   component of at least ``min_area_px`` with ``multi_instance``).
4. part ``"top"``: the instance pixels within ``top_band`` of the object's highest point above the
   plane (robust 95th percentile); without depth, the whole object. Parts a colour segmenter cannot
   separate (any other name) are the whole object.

``score`` is the kept pixels' share of the colour-matching pixels that survived step 2 (how dominant
the chosen component is), 0 when nothing was found.
"""

from __future__ import annotations

import cv2
import numpy as np

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.core.errors import PerceptionError
from code_as_monitor.core.observation import View
from code_as_monitor.perception.segmenters.base import ColorSegmenterConfig, Segmenter, SegmentResult


def fit_plane_ransac(
    points: np.ndarray, inlier: float, iters: int, rng: np.random.Generator
) -> tuple[np.ndarray, float] | None:
    """Dominant plane ``n . p + d = 0`` of a cloud (N, 3) metres: unit normal (3,) and offset d.

    RANSAC over ``iters`` random triplets, then a least-squares refit on the inliers. None when the
    cloud has fewer than 3 points or only degenerate triplets.
    """
    P = np.asarray(points, dtype=np.float64)
    if len(P) < 3:
        return None
    tri = P[rng.integers(0, len(P), size=(iters, 3))]  # (iters, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    ok = norm > 1e-9
    if not ok.any():
        return None
    n = n[ok] / norm[ok, None]
    d = -(n * tri[ok, 0]).sum(axis=1)
    counts = (np.abs(P @ n.T + d) < inlier).sum(axis=0)
    best = int(np.argmax(counts))
    inl = P[np.abs(P @ n[best] + d[best]) < inlier]
    if len(inl) < 3:
        return n[best], float(d[best])
    c = inl.mean(axis=0)
    normal = np.linalg.svd(inl - c, full_matrices=False)[2][2]
    return normal, float(-normal @ c)


class ColorSegmenter(Segmenter):
    """HSV colour thresholds + table-plane removal + morphology + connected components."""

    def __init__(self, config: ColorSegmenterConfig | None = None) -> None:
        from code_as_monitor.geometry import backproject_pixels

        self._lift = backproject_pixels
        self.config = config or ColorSegmenterConfig()

    def colour_of(self, obj: str) -> str:
        """The colour name for object ``obj``; PerceptionError naming it when there is none."""
        c = self.config
        if obj in c.object_colors:
            return c.object_colors[obj]
        for tok in obj.lower().split("_"):
            if tok in c.colors:
                return tok
        raise PerceptionError(
            f"color segmenter: unknown object {obj!r}: its name holds no known colour "
            f"({', '.join(sorted(c.colors))}); map it in object_colors"
        )

    def segment(self, view: View, spec: ElementSpec, constraint_text: str = "") -> SegmentResult:
        c = self.config
        colour = self.colour_of(spec.obj)
        if colour not in c.colors:
            raise PerceptionError(f"color segmenter: object {spec.obj!r} maps to unknown colour {colour!r}")
        hsv = cv2.cvtColor(view.rgb, cv2.COLOR_RGB2HSV)
        cand = np.zeros(hsv.shape[:2], dtype=np.uint8)
        for lo, hi in c.colors[colour]:
            cand |= cv2.inRange(hsv, np.array(lo, np.uint8), np.array(hi, np.uint8))
        shape = cand.shape
        if not cand.any():
            return SegmentResult.nothing(shape, spec.kind)

        height = np.full(shape, np.nan)  # metres above the table plane, NaN = unknown
        plane = self._table_plane(view)
        if plane is not None:
            rows, cols = np.nonzero(cand)
            pts, valid = self._lift(np.stack([cols, rows], 1).astype(np.float64), view.depth, view.camera, c.max_depth)
            h = np.full(len(rows), np.nan)
            h[valid] = pts[valid] @ plane[0] + plane[1]
            height[rows, cols] = h
            if spec.obj not in c.flat_objects:
                with np.errstate(invalid="ignore"):
                    cand[height < c.min_height] = 0

        mask = self._cleanup(cand)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        areas = stats[1:, cv2.CC_STAT_AREA]
        if n <= 1 or areas.max() < c.min_area_px:
            return SegmentResult.nothing(shape, spec.kind)
        keep = (np.flatnonzero(areas >= c.min_area_px) if c.multi_instance else [int(np.argmax(areas))])
        instance = np.isin(labels, np.asarray(keep) + 1)
        score = float(min(1.0, instance.sum() / max(1, int(np.count_nonzero(cand)))))
        part = instance
        if spec.part == "top":
            part = self._top(instance, height)
        return SegmentResult(instance, part.copy() if part is instance else part, spec.kind, score)

    # --- steps ------------------------------------------------------------------------------------
    def _table_plane(self, view: View) -> tuple[np.ndarray, float] | None:
        """(normal (3,), d) of the dominant plane in world coordinates, normal towards the camera."""
        c = self.config
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(view.depth) & (view.depth > 0) & (view.depth <= c.max_depth)
        rows, cols = np.nonzero(ok)
        if len(rows) < 3:
            return None
        rng = np.random.default_rng(c.seed)
        pick = rng.choice(len(rows), size=min(c.plane_samples, len(rows)), replace=False)
        uv = np.stack([cols[pick], rows[pick]], 1).astype(np.float64)
        pts, valid = self._lift(uv, view.depth, view.camera, c.max_depth)
        fit = fit_plane_ransac(pts[valid], c.plane_inlier, c.plane_iters, rng)
        if fit is None:
            return None
        normal, d = fit
        if normal @ view.camera.position + d < 0:
            normal, d = -normal, -d
        return normal, d

    def _cleanup(self, mask: np.ndarray) -> np.ndarray:
        c = self.config
        out = mask
        for op, k in ((cv2.MORPH_OPEN, c.open_px), (cv2.MORPH_CLOSE, c.close_px)):
            if k > 1:
                out = cv2.morphologyEx(out, op, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
        return out

    def _top(self, instance: np.ndarray, height: np.ndarray) -> np.ndarray:
        h = height[instance]
        h = h[np.isfinite(h)]
        if h.size < self.config.min_area_px:
            return instance  # no usable depth: the whole object
        top = np.percentile(h, 95.0)
        with np.errstate(invalid="ignore"):
            return instance & (height >= top - self.config.top_band)
