"""Elements from generic keypoints instead of constraint-aware part masks (the ablation "CS off").

The paper's row used DINOv2 feature points; offline we use a classical stand-in and name it plainly: **ORB
keypoints (OpenCV) on the object's image region, lifted with depth, clustered with scikit-learn k-means**. It is
not DINOv2, and, like generic points, it knows nothing of parts or of the constraint:

1. per view, ORB keypoints of the grey image inside the object's *instance* mask (the object's image region; no
   part mask is read), each lifted to the world with the view's depth at its pixel;
2. the keypoints of every view are pooled (world frame, metres);
3. an element of kind point is their mean; a line is the centres of k = 2 k-means clusters (the higher end
   first); a surface the centres of k = 4 clusters, counter-clockwise about their mean seen from the side their
   fitted plane's normal points to (normal up).

So two parts of one object asked for with the same kind get the same element (a pen's tip and body are both its
keypoints' mean), and a part that is a small piece of a large object (a shelf's slot) is represented by the whole
object's keypoints. Fewer pooled keypoints than the element needs clusters: no element (the painter reports it
missing, as it does for an object no view sees).
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from code_as_monitor.core.elements import Element, ElementKind, ElementSpec
from code_as_monitor.core.errors import CamError

ORB_FEATURES = 200
"""Keypoints asked of ORB per view and object."""
ORB_PATCH = 9
"""ORB's patch size and edge threshold, pixels: small, as objects cover a few thousand pixels of a 320 x 240 view."""
ORB_FAST_THRESHOLD = 5
"""FAST's intensity threshold (flat-shaded simulator objects have weak corners)."""
CLUSTERS = {ElementKind.POINT: 1, ElementKind.LINE: 2, ElementKind.SURFACE: 4}
"""k-means clusters per element kind."""


def orb_keypoints(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """ORB keypoint pixels ``(N, 2)`` (u = column, v = row, int) of ``rgb`` (H, W, 3) uint8 inside ``mask`` (H, W)."""
    gray = cv2.cvtColor(np.ascontiguousarray(rgb, dtype=np.uint8), cv2.COLOR_RGB2GRAY)
    orb = cv2.ORB_create(nfeatures=ORB_FEATURES, nlevels=3, edgeThreshold=ORB_PATCH, patchSize=ORB_PATCH,
                         fastThreshold=ORB_FAST_THRESHOLD)
    kps = orb.detect(gray, np.asarray(mask, dtype=np.uint8) * 255)
    if not kps:
        return np.zeros((0, 2), dtype=int)
    uv = np.array([k.pt for k in kps], dtype=np.float64)
    h, w = gray.shape
    uv = np.rint(uv).astype(int)
    uv[:, 0] = np.clip(uv[:, 0], 0, w - 1)
    uv[:, 1] = np.clip(uv[:, 1], 0, h - 1)
    return uv


def lifted_keypoints(rgb: np.ndarray, mask: np.ndarray, lifted: Any) -> np.ndarray:
    """World points ``(N, 3)`` of the ORB keypoint pixels inside ``mask`` (H, W) with a depth reading; ``lifted`` is
    the view's :class:`~code_as_monitor.geometry.backproject.LiftedView` (one point per keypoint pixel)."""
    uv = orb_keypoints(rgb, mask)
    if len(uv) == 0:
        return np.zeros((0, 3))
    at = np.zeros(np.asarray(mask).shape, dtype=bool)
    at[uv[:, 1], uv[:, 0]] = True
    return lifted.points(at & np.asarray(mask, dtype=bool))


def ccw_about_normal(corners: np.ndarray) -> np.ndarray:
    """``corners`` (k, 3) ordered counter-clockwise about their mean, seen from where their plane's normal (chosen
    with z >= 0) points."""
    c0 = corners.mean(axis=0)
    _, _, vt = np.linalg.svd(corners - c0)
    n = vt[2] if vt[2][2] >= 0 else -vt[2]
    e1 = vt[0]
    e2 = np.cross(n, e1)
    d = corners - c0
    return corners[np.argsort(np.arctan2(d @ e2, d @ e1))]


def element_from_keypoints(eid: int, spec: ElementSpec, keypoints: np.ndarray, seed: int = 0) -> Element | None:
    """The element of ``spec`` from pooled keypoints ``(N, 3)`` world metres (see the module docstring); None when
    there are fewer keypoints than clusters or the clusters are degenerate (coincident or collinear)."""
    from sklearn.cluster import KMeans

    P = np.asarray(keypoints, dtype=np.float64).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    k = CLUSTERS[spec.kind]
    if len(np.unique(np.round(P, 4), axis=0)) < k:
        return None
    owner = (spec.obj, spec.part)
    if k == 1:
        el = Element.point(eid, spec.name, P.mean(axis=0), owner)
    else:
        centres = KMeans(n_clusters=k, n_init=4, random_state=seed).fit(P).cluster_centers_
        try:
            if spec.kind is ElementKind.LINE:
                hi, lo = sorted(centres, key=lambda c: -c[2])
                el = Element.line(eid, spec.name, hi, lo, owner)
            else:
                el = Element.surface(eid, spec.name, ccw_about_normal(centres), owner)
        except CamError:  # coincident ends, collinear corners
            return None
    el.cloud = P[:2000]
    el.object_cloud = el.cloud
    return el


def keypoint_element(eid: int, spec: ElementSpec, views: list[tuple], min_pixels: int) -> Element | None:
    """The element of ``spec`` from per-view ``(view, LiftedView, SegmentResult)``: ORB keypoints inside each view's
    instance mask (of at least ``min_pixels`` pixels), pooled, clustered."""
    pooled = [lifted_keypoints(view.rgb, res.instance_mask, lifted) for view, lifted, res in views
              if int(np.asarray(res.instance_mask).sum()) >= min_pixels]
    if not pooled:
        return None
    return element_from_keypoints(eid, spec, np.concatenate(pooled, axis=0))


__all__ = ["CLUSTERS", "ccw_about_normal", "element_from_keypoints", "keypoint_element", "lifted_keypoints",
           "orb_keypoints"]
