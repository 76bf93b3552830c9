"""Re-acquisition of a lost body in the depth tracker: its known model registered to a fresh segmentation of its
object, from where it was searched, from the segmentation's centroid, and along the model's long axis.

See :mod:`code_as_monitor.perception.trackers.depth` for the method. Poses are (4, 4) rigid transforms from the body's
model frame (the world at paint time) to the world now.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.geometry.transforms import rotation_onto
from code_as_monitor.perception.trackers.base import DepthTrackerConfig
from code_as_monitor.perception.trackers.depth_body import apply, support
from code_as_monitor.perception.trackers.depth_search import BodyState, score, search
from code_as_monitor.perception.trackers.depth_views import Plane, ViewData


def relocate(c: DepthTrackerConfig, body: BodyState, cloud: np.ndarray, views: list[ViewData],
             plane: Plane | None) -> bool:
    """Re-acquire a lost body from a fresh segmentation of its object (``cloud`` (N, 3), world): its model is
    registered to the cloud from where it was searched, from there shifted onto the cloud's centroid, and
    from the two poses along the model's long axis that the views explain best (:func:`_along_axis`), under
    the search's checks (evidence in the views, at most ``max_rotation`` turned). Found, the body keeps its
    model at the new pose (its parts keep their relation to it) and True is returned."""
    if body.model is None or len(cloud) < c.min_points:
        return False
    cloud = np.asarray(cloud, dtype=np.float64)
    T0 = body.T_search
    shifted = T0.copy()
    shifted[:3, 3] += cloud.mean(axis=0) - apply(T0, body.model.centre[None])[0]
    found = search(c, body, views, cloud, [[T0, shifted, *_along_axis(c, body, T0, cloud, views)]],
                    None if body.model.in_plane else plane)
    if found is None:
        return False
    body.T_prev = body.T = body.T_search = found[0]
    body.last, body.moved, body.seen_views = found[1], 0.0, found[1].views
    body.lost, body.lost_before, body.lost_frames = False, body.lost_frames, 0
    return True


def _along_axis(c: DepthTrackerConfig, body: BodyState, T0: np.ndarray, cloud: np.ndarray,
                views: list[ViewData]) -> list[np.ndarray]:
    """Poses along the model's long axis, which registration barely constrains (a pen that slid down its
    holder, or leans in it): from ``T0``, and from ``T0`` turned so that the model's long axis lies along the
    cloud's (about the model's centre, put on the cloud's axis), shifted in ``2 * voxel`` steps up to the
    model's radius; the two whose projection the views explain best (seen points, contradicted ones costing
    three)."""
    assert body.model is not None
    P = body.model.points
    a_model = T0[:3, :3] @ np.linalg.svd(P - P.mean(axis=0), full_matrices=False)[2][0]
    mid = cloud.mean(axis=0)
    a_cloud = np.linalg.svd(cloud - mid, full_matrices=False)[2][0]
    a_cloud = a_cloud if a_cloud @ a_model >= 0 else -a_cloud
    ctr = apply(T0, body.model.centre[None])[0]
    turned = np.eye(4)
    turned[:3, :3] = rotation_onto(a_model, a_cloud)
    on_line = mid + ((ctr - mid) @ a_cloud) * a_cloud
    turned[:3, 3] = on_line - turned[:3, :3] @ ctr
    scored = []
    for base, axis in ((T0, a_model), (turned @ T0, a_cloud)):
        for d in np.arange(-body.model.radius, body.model.radius + 1e-9, 2 * c.voxel):
            T = base.copy()
            T[:3, 3] += d * axis
            scored.append((score(support(apply(T, P), views, c.depth_tol, c.max_depth)), T))
    return [T for _, T in sorted(scored, key=lambda x: -x[0])[:2]]
