"""Bodies that claim the same surface, in the depth tracker: two objects on one surface, and a part that
slid along its own object.

Poses are (4, 4) rigid transforms from a body's model frame (the world at its paint time) to the world
now. See :mod:`code_as_monitor.perception.trackers.depth` for the method.
"""

from __future__ import annotations

import logging

import numpy as np

from code_as_monitor.perception.trackers.base import DepthTrackerConfig
from code_as_monitor.perception.trackers.depth_body import apply, invert, support
from code_as_monitor.perception.trackers.depth_search import BodyState, centre_shift, pose_support
from code_as_monitor.perception.trackers.depth_views import ViewData

log = logging.getLogger(__name__)


def on_surface(c: DepthTrackerConfig, body: BodyState, T: np.ndarray, other: BodyState) -> float:
    """Fraction of ``body``'s model points, at world pose ``T``, that lie within ``depth_tol`` of ``other``'s
    model surface at its current pose."""
    assert body.model is not None and other.model is not None
    P = apply(invert(other.T) @ T, body.model.points)
    _, d2 = other.model.tree.batch_nearest_neighbor_search(P)
    return float(np.mean(np.sqrt(np.asarray(d2)) <= c.depth_tol))


def own_evidence(c: DepthTrackerConfig, part: BodyState, parent: BodyState, views: list[ViewData]) -> int:
    """How many of ``part``'s model points, at its current pose, are seen off ``parent``'s model surface
    (farther than ``depth_tol`` from it): the evidence for the part's pose that its object's surface does
    not also give."""
    assert part.model is not None and parent.model is not None
    P = apply(part.T, part.model.points)
    _, d2 = parent.model.tree.batch_nearest_neighbor_search(apply(invert(parent.T), P))
    off = np.sqrt(np.asarray(d2)) > c.depth_tol
    return support(P[off], views, c.depth_tol, c.max_depth).seen if off.any() else 0


def resolve_overlaps(c: DepthTrackerConfig, bodies: list[BodyState]) -> None:
    """Two bodies of different objects cannot occupy the same space: when one's model points mostly
    lie on the other's surface (an identical block slid onto its neighbour), the body painted
    longer ago, or on a tie the one that moved further this frame, is lost."""
    live = [b for b in bodies if b.model is not None and not b.lost]
    if len(live) < 2:
        return
    centres = np.array([apply(b.T, b.model.centre[None])[0] for b in live])  # type: ignore[union-attr]
    radii = np.array([b.model.radius for b in live])  # type: ignore[union-attr]
    near = np.linalg.norm(centres[:, None] - centres[None], axis=2) <= radii[:, None] + radii[None]
    for i, j in zip(*np.nonzero(np.triu(near, 1))):
        a, b = live[i], live[j]
        if a.owner[0] == b.owner[0] or a.lost or b.lost:
            continue
        assert a.model is not None and b.model is not None
        small, big = (a, b) if len(a.model.points) <= len(b.model.points) else (b, a)
        if on_surface(c, small, small.T, big) < c.max_overlap:
            continue
        loser = min((a, b), key=lambda x: (x.painted, -x.moved))  # painted earlier, else moved further
        log.debug("bodies %s and %s overlap: %s lost", a.owner, b.owner, loser.owner)
        loser.T, loser.T_search = loser.T_prev, loser.T_prev
        loser.lost, loser.lost_frames, loser.seen_views = True, loser.lost_before + 1, 0


def keep_on_object(c: DepthTrackerConfig, part: BodyState, parent: BodyState, views: list[ViewData]) -> None:
    """Keep a part (``part``) where its object (``parent``, registered this frame) carries it, unless the part moved on
    its own. Call after the part's own frame.

    A part can leave its object's pose only into space its object did not fill (a drawer's handle pulled out in
    front of the cabinet, a lid lifted off its pot): a registration more than ``depth_tol`` from where the object
    carries it is the part's own move, and updates its pose relative to the object (``rel``), when at least
    ``min_seen`` of its points (the evidence any pose needs) are seen off the object's model surface and either the
    end-effector holds the part or the frame denies it where the object carries it (below). With fewer, its evidence
    is the object's own surface: the part's few points matched the object's other points (a pen's tip, hidden as it
    enters a holder, slides up the pen's visible body): it slid. Where the frame does not deny the object's
    placement, points seen elsewhere are another surface's (the pen's tip, entering the holder with the pen well
    registered, registered 3.5 cm off onto the holder's wall, and stayed there after the release). A slid part, or
    one the frame lost, is put where the object carries it when the frame does not deny it there (at most
    ``max_contradiction`` of its points in view read behind it; points hidden by a nearer surface deny nothing: a
    stick's end seen moving along the stick while the uniform stick registers unmoved is denied there); its evidence
    is then the object's registration (``on_parent``) and it has none of its own (``last`` is None: with its object
    lost the next frame it is not kept where it was on its few points but searched like a lost body). Denied, the
    part's own result stands (its registration, or lost: stale). The frame also denies the carry when it contradicts
    at least ``min_seen`` more of the part's points there than at the part's own passing pose: a cabinet's frame,
    registered unmoved, is not dragged by its whole body, which the end-effector pulls by the handle (the part is
    then ``apart``: next frame it is first tried where it was, not where its object took it)."""
    part.apart = False
    if part.model is None or parent.model is None or parent.lost or part.rel is None:
        return
    T_rigid = parent.T @ part.rel
    if not part.lost and centre_shift(part.model, part.T, T_rigid) <= c.depth_tol:
        return
    sup = pose_support(c, part.model, T_rigid, views)
    own = None if part.lost else part.last  # its own result this frame (a part placed on its object has none)
    denied = (sup.contradicted > c.max_contradiction * max(sup.seen + sup.contradicted + sup.occluded, 1)
              or (own is not None and sup.contradicted >= own.contradicted + c.min_seen))
    if not part.lost and (part.held or denied) and own_evidence(c, part, parent, views) >= c.min_seen:
        part.rel = invert(parent.T) @ part.T  # it moved on its own
        return
    if not part.lost and part.held and own is not None and own.contradicted <= sup.contradicted:
        part.rel = invert(parent.T) @ part.T  # the grip moved it, and the frame denies it there no more
        return
    if denied:
        part.apart = not part.lost
        return  # the frame denies it where the object carries it: the part's own result stands
    if not part.lost:
        part.T = part.T_prev  # the slid registration is not a pose the part had
    part.moved = centre_shift(part.model, part.T, T_rigid)
    part.T_prev, part.T, part.T_search = part.T, T_rigid, T_rigid
    part.last = None  # no evidence of its own: next frame it is not kept unmoved on it (its object may be lost)
    part.lost, part.lost_before, part.lost_frames = False, part.lost_frames, 0
    part.seen_views, part.on_parent = parent.seen_views, True
