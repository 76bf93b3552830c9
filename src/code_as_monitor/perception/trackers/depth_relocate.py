"""Re-acquisition of a lost body in the depth tracker: its known model registered to a fresh segmentation of its
object, from where it was searched, from the segmentation's centroid, and along the model's long axis.

See :mod:`code_as_monitor.perception.trackers.depth` for the method. Poses are (4, 4) rigid transforms from the body's
model frame (the world at paint time) to the world now.

How much of the model must be seen. Tracking asks a pose to see ``min_seen_frac`` of the model points seen at paint
time. A fresh segmentation of the object is evidence of its own: the segmenter found the object there. For a body the
gripper carried (searched where the end-effector's motion took it, :func:`keep_known`), when no pose passes tracking's
bar, the pose registered from there that sees ``min_seen`` model points, is contradicted no more than tracking allows,
and puts :data:`SEGMENT_SHARE` of the segmentation's points on the model's surface has found the object, even when it
now shows only a small part of itself (a book lowered into its shelf: its model saw 473 points when painted in the
gripper; the slot and the gripper left 34 in view; stow-book (b), seed 1822091572).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from code_as_monitor.core.elements import Element
from code_as_monitor.geometry.transforms import rotation_onto
from code_as_monitor.perception.trackers.base import DepthTrackerConfig
from code_as_monitor.perception.trackers.depth_body import apply, invert, support
from code_as_monitor.perception.trackers.depth_search import BodyState, Owner, pose_support, score, search
from code_as_monitor.perception.trackers.depth_views import Plane, ViewData

SEGMENT_SHARE = 0.75
"""The share of a fresh segmentation's points a relocated model must explain (within :func:`share_on_model`'s reach of
the model's points) when it passes on ``min_seen`` points rather than tracking's bar: three quarters of what the
segmenter found there is the known object's surface."""
HIDDEN_CONTRADICTED = 0.1
"""The most of a lost body's readable points (seen + seen through) at its last pose that may be seen through for the
frame to leave it where it was (:func:`hidden_where_it_was`); more, and it moved."""


def share_on_model(body: BodyState, T: np.ndarray, cloud: np.ndarray, reach: float) -> float:
    """The share of ``cloud`` (N, 3) world points within ``reach`` metres of ``body``'s model points at pose ``T`` (the
    model's own KdTree, as :func:`.depth_claims.on_surface` asks it of a body's points)."""
    assert body.model is not None
    local = apply(invert(T), np.asarray(cloud, dtype=np.float64).reshape(-1, 3))
    if not len(local):
        return 0.0
    _, d2 = body.model.tree.batch_nearest_neighbor_search(local)
    return float(np.mean(np.sqrt(np.asarray(d2)) <= reach))


def relocate(c: DepthTrackerConfig, body: BodyState, cloud: np.ndarray, views: list[ViewData],
             plane: Plane | None, on_segmentation: bool = False) -> bool:
    """Re-acquire a lost body from a fresh segmentation of its object (``cloud`` (N, 3), world): its model is
    registered to the cloud from where it was searched, from there shifted onto the cloud's centroid, and
    from the two poses along the model's long axis that the views explain best (:func:`_along_axis`), under
    the search's checks (evidence in the views, at most ``max_contradiction``; at most ``max_rotation`` turned), or,
    with ``on_segmentation``, when none passes them, registered from where it was searched alone on the segmentation's
    own evidence (the module docstring). Found, the body keeps its model at the new pose (its parts keep their relation
    to it) and True is returned; found on the segmentation's evidence, the points it sees now become the reference
    tracking's ``min_seen_frac`` is taken of (the book in its shelf is followed on what the slot and the gripper leave
    in view)."""
    if body.model is None or len(cloud) < c.min_points:
        return False
    cloud = np.asarray(cloud, dtype=np.float64)
    T0 = body.T_search
    shifted = T0.copy()
    shifted[:3, 3] += cloud.mean(axis=0) - apply(T0, body.model.centre[None])[0]
    tiers = [[T0, shifted, *_along_axis(c, body, T0, cloud, views)]]
    plane = None if body.model.in_plane else plane
    found = search(c, body, views, cloud, tiers, plane)
    if found is None and not on_segmentation:
        return False
    if found is None:  # showing little of itself: on the segmentation's own evidence
        found = search(c, body, views, cloud, [[T0]], plane, need=c.min_seen)
        reach = 1.5 * body.model.voxel + c.depth_tol
        if found is None or share_on_model(body, found[0], cloud, reach) < SEGMENT_SHARE:
            return False
        body.ref_seen = max(found[1].seen, c.min_seen)  # followed on what it shows now
    body.T_prev = body.T = body.T_search = found[0]
    body.last, body.moved, body.seen_views = found[1], 0.0, found[1].views
    body.lost, body.lost_before, body.lost_frames = False, body.lost_frames, 0
    return True


def keep_known(c: DepthTrackerConfig, body: BodyState, bodies: Mapping[Owner, BodyState], new: Element,
               views: list[ViewData], plane: Plane | None) -> bool:
    """Whether lost ``body`` keeps its known model rather than take ``new``, the re-paint of one of its elements: only
    for a body the gripper carried when it was lost (``held``: where the end-effector's motion took it is where it is
    searched), when the painter calls the re-paint weak (``new.support.weak()``: a side assumed, few points or views,
    its part unseen) and the known model relocates onto the re-paint's segmentation (:func:`relocate`, also on the
    segmentation's own evidence). A body at rest has no such prior: a book's spine, re-painted weak while the
    gripper closed on the book, relocated 41 degrees turned (stow-book (a), seed 1230431832). Its parent in
    ``bodies`` (the whole object), when lost, is relocated onto the object's segmentation too, searched from where
    the part's relation to it puts it (a whole book that only its parts use is not followed once lost, nor carried
    with the gripper: searched from where it was lost, 11 cm above, the visible strip of its covers fitted it there).
    A weak paint of a half-hidden object is centimetres off (the painter's element benchmark: a book in its shelf, 97
    mm), while the known model, painted when the object was in view and placed where the fresh segmentation says it
    is, keeps its elements where they are on it."""
    sup = new.support
    cloud = new.cloud if new.cloud is not None and len(new.cloud) else new.object_cloud
    if body.model is None or not body.held or sup is None or not sup.weak() or cloud is None:
        return False
    if not relocate(c, body, cloud, views, plane, on_segmentation=True):
        return False
    parent = bodies.get(body.parent) if body.parent is not None else None
    if parent is not None and parent.lost and new.object_cloud is not None and len(new.object_cloud):
        if body.rel is not None:  # searched where the part found says it is, not where it was lost
            parent.T_search = body.T @ invert(body.rel)
        relocate(c, parent, new.object_cloud, views, plane, on_segmentation=True)
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


def hidden_where_it_was(c: DepthTrackerConfig, body: BodyState, views: list[ViewData]) -> bool:
    """Whether this frame leaves a lost ``body`` where it was last found: at its last pose its model is seen through
    (contradicted) by at most ``HIDDEN_CONTRADICTED`` of the points the frame can read there (seen + contradicted); a
    body only hidden (by the arm) has most of its points occluded and almost none seen through. A weak re-paint of such
    a body is no evidence that it moved (stack p = 0.15, 1739362667: a block at rest lost three frames beside the arm,
    5 points seen, 0 seen through, 320 occluded, re-painted from 9 points of one view 2.8 cm off, while its last pose
    was within 1.4 mm of the truth). A body moved while lost is seen through where it was and takes the re-paint
    (stow-book (a) 595344089: the book turned 53 degrees about its centre under the descending gripper still covers
    much of its old place, 93 points seen, 54 seen through; the first form of this rule, seen through by no more than
    seen, kept its stale pose and the turned book read 52 degrees from upright for 30 re-plans)."""
    if body.model is None:
        return False
    sup = pose_support(c, body.model, body.T, views)
    return sup.contradicted <= HIDDEN_CONTRADICTED * (sup.seen + sup.contradicted)
