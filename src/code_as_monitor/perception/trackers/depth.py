"""Depth tracker: each element's object or part followed in 3-D by registering its painted cloud to the
current depth images of all views (small_gicp), with no per-frame segmentation and no simulator pose.

Bodies. Elements are grouped by owner ``(object, part)``; each group is one rigid *body* whose model is
the owner's cloud at paint time (``Element.cloud``: the part's mask for a part, the instance's for a
whole object). A part element whose element also carries the whole object's cloud
(``Element.object_cloud``) gets that object as its *parent* body: the parent is registered first and
its motion is one of the part's guesses, so a part rigid with its object (a block's top, a teapot's
lid) moves with the well-constrained whole, while a part that moves on its own (a drawer handle on a
prismatic drawer, a rope bead) is registered from its own cloud and wins by its own evidence.
An element's points move with its body's pose: ``p_now = T_body @ p_painted``. Per frame and body:

1. guesses of the pose: where it was; where the end-effector's motion since the last frame took it,
   when the gripper or suction is on and the tip was within ``held_distance`` of the body; the parent's
   motion; constant velocity and a ballistic fall, when it moved last frame (a just-released held body
   is tried a free-fall step below the gripper too);
2. the depth images are cropped around the guesses (image box + world box), points on the support
   plane (the dominant plane, fitted at reset) and on the end-effector (a cylinder up the tool axis from
   the tip) are removed, and the rest is voxel-downsampled: the registration source;
3. from each guess in turn, coarse-to-fine ICP (``registration``, ``max_correspondence``) of the source
   to the body's model; each result is checked projectively (:func:`.depth_body.support`): enough
   model points must be seen at their predicted depth (``min_seen``, ``min_seen_frac`` of the count
   seen at paint time) and few contradicted by a reading behind them (``max_contradiction``). The
   first guess whose registration barely moved it and passes ends the search; otherwise the passing
   result with the most evidence wins among those the frame contradicts no more than the last pose (seen
   points cannot tell poses apart along an axis the shape leaves free: a pen let go slides down its holder);
   a body just let go whose results are all more contradicted climbs its projective evidence to one that is not;
4. no passing result: the body is *lost* this frame and its elements are stale (they keep their last good
   points; nothing is guessed). A lost body keeps being searched from its last pose (and, while held, from
   where the end-effector carried it). After ``reacquire_after`` lost frames the hook set by :meth:`set_reacquire`
   re-segments its elements (the agent re-runs the painter); their clouds become the body's new model (a part
   re-painted from its whole object's masks where its earlier paint had seen it is refused: stale), except
   that a lost whole object whose known model registers to its new segmentation keeps that model
   (:func:`.depth_relocate.relocate`), and its parts their place on it, and that a carried body's weak re-paint does
   not replace its known model when that relocates (:func:`.depth_relocate.keep_known`), nor a weak re-paint of a
   body the frame leaves where it was (:func:`.depth_relocate.hidden_where_it_was`). A part too small to
   register alone (:func:`.depth_detect.is_small`) whose object is lost, with no other part moving it, is not searched
   for (its few points fit nearby surfaces): stale rather than wrong;
5. claims (:mod:`.depth_claims`), after every body's frame: two objects on one surface lose the one painted
   longer ago; then a part whose registration left where its object carries it without ``min_seen`` points
   seen off the object's surface slid along it (a pen's tip hidden in a holder matched the pen's visible
   body), and it, or a part lost this frame, is placed where its registered object carries it unless the
   frame contradicts it there: a rigid part hidden by another object is followed with its object.

Small bodies. A body too small to register (:func:`.depth_detect.is_small`: few points or a small extent
of its painted cloud, measured, never named) is followed by detection when the tracker has the painter's
segmenter (:meth:`set_segmenter`): each frame the segmenter's masks are lifted to anonymous 3-D centroids and
associated to the small bodies by position (:mod:`code_as_monitor.perception.trackers.depth_detect`). A small
part does not make its whole object a body. Support (``TrackResult.support``): the model points a registered
body's pose saw, summed over the views; small bodies report none.

Elements owned by the robot follow forward kinematics (:class:`.anchor.KinematicAnchor`). An element
without a cloud (not built from masks) cannot be registered: it is stale until the hook re-paints it.
A view whose depth or camera is unusable is skipped for the frame with a logged warning.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from code_as_monitor.core.elements import Element, ElementSpec, stood_in
from code_as_monitor.core.errors import CamError, PerceptionError
from code_as_monitor.core.observation import Observation, engaged
from code_as_monitor.perception.trackers.anchor import KinematicAnchor
from code_as_monitor.perception.trackers.base import DepthTrackerConfig, Tracker, TrackResult
from code_as_monitor.perception.trackers.depth_body import RigidBody, apply, invert, model_chroma, support
from code_as_monitor.perception.trackers.depth_claims import keep_on_object, resolve_overlaps
from code_as_monitor.perception.trackers.depth_detect import (
    SmallBody,
    init_offsets,
    is_small,
    model_points,
    principal_extent,
    registrable_objects,
    track_small,
)
from code_as_monitor.perception.trackers.depth_detections import ViewDetections, detect
from code_as_monitor.perception.trackers.depth_relocate import hidden_where_it_was, keep_known, relocate
from code_as_monitor.perception.trackers.depth_search import BodyState, Owner, moves_body, track_body
from code_as_monitor.perception.trackers.depth_views import Plane, ViewData, fit_support_plane

log = logging.getLogger(__name__)


class DepthTracker(Tracker):
    """Streaming multi-view depth-registration tracker (see the module docstring)."""

    def __init__(self, config: DepthTrackerConfig | None = None) -> None:
        super().__init__()
        self.config = config or DepthTrackerConfig()
        self._order: list[int] = []
        self._elements: dict[int, Element] = {}
        self._anchors: dict[int, KinematicAnchor] = {}
        self._bodies: dict[Owner, BodyState] = {}
        self._small: dict[Owner, SmallBody] = {}  # bodies followed by detection
        self._registrable: set[str] = set()  # objects with an element big enough to register
        self._local: dict[int, np.ndarray] = {}  # element id -> (k, 3) model-frame points
        self._body_of: dict[int, Owner | None] = {}  # None: no cloud, never registered
        self._last: dict[int, np.ndarray] = {}  # element id -> last reported points
        self._plane: Plane | None = None
        self._ee: np.ndarray | None = None  # (4, 4) end-effector pose at the previous frame
        self._tip_prev: np.ndarray | None = None  # (3,) tool tip at the previous frame
        self._t: float | None = None
        self._warned: set[str] = set()
        self._unbodied: dict[int, int] = {}  # element id -> stale frames, for elements without a body
        self._fresh: set[int] = set()  # elements re-painted this frame (fresh although their body is new)
        self._frame = 0  # frames seen since construction (orders the bodies' paint times)

    # --- public API -------------------------------------------------------------------------------
    def reset(self, obs: Observation, elements: list[Element]) -> None:
        self._order = [el.id for el in elements]
        self._elements = {el.id: el for el in elements}
        self._anchors.clear()
        self._bodies.clear()
        self._small.clear()
        self._local.clear()
        self._body_of.clear()
        self._unbodied.clear()
        self._fresh.clear()
        self._last = {el.id: el.points.copy() for el in elements}
        views = self._usable_views(obs)
        self._plane = fit_support_plane(views, self.config.plane_band, self.config.max_depth)
        self._registrable = registrable_objects(elements, self.config, self._plane) if self._segmenter else set()
        for el in elements:
            if el.owner[0] in self.config.kinematic_owners:
                self._anchors[el.id] = KinematicAnchor(obs, el)
            else:
                self._attach(el, views)
        for sb in self._small.values():
            sb.t = obs.t
        init_offsets(list(self._small.values()), self._detect(obs, views), self.config.detect_gate)
        self._ee = _ee_pose(obs)
        self._tip_prev = obs.tip
        self._t = obs.t
        # a body painted in the jaws is carried from the first frame (a pen re-painted as a re-plan began, then
        # swung 3.4 cm in one frame, was lost, and re-found 11.6 cm off: a false "pen dropped")
        self._update_held(self._tip_prev, engaged(obs))

    def step(self, obs: Observation) -> TrackResult:
        c = self.config
        self._frame += 1
        views = self._usable_views(obs)
        ee = _ee_pose(obs)
        dT_ee = ee @ invert(self._ee) if (ee is not None and self._ee is not None) else None
        on = engaged(obs)
        tip = obs.tip  # read once per frame
        tool = _tool(obs, ee, tip, c.tool_radius, c.tool_margin) if ee is not None and c.tool_radius > 0 else None
        dt = obs.t - self._t if self._t is not None else 0.0
        moves: dict[Owner, np.ndarray] = {}  # body -> this frame's rigid motion (for its parts)
        parents = {b.parent for b in self._bodies.values()}  # the bodies that carry parts of their own
        for owner in self._ordered_bodies():
            body = self._bodies[owner]
            if not body.elements and owner not in parents:
                continue  # a whole object created for parts that are all followed by detection
            if not body.elements and body.lost and body.lost_frames > c.reacquire_after:
                continue  # a whole object only its parts use, lost for good (a rope that bent): parts go alone
            related = []
            if body.parent is not None:  # parts of the same object that moved, then the whole object
                related = self._nearest_moved(body, moves, c.related_parts)
                if body.parent in moves:
                    related.append(moves[body.parent])
            before = body.T.copy()
            alone = body.parent is not None and body.parent not in moves and not related  # its object lost
            body.on_parent = False
            track_body(c, body, views, self._plane, dT_ee if (on and body.held) else None, related, dt, tool, alone,
                       carried_first=owner not in parents)
            if not body.lost:
                moves[owner] = body.T @ invert(before)
        resolve_overlaps(c, list(self._bodies.values()))  # first: a part slid onto another object is lost
        for body in self._bodies.values():  # a part not slid along its object, nor lost where it carries it
            if body.parent in moves and not self._bodies[body.parent].lost:
                keep_on_object(c, body, self._bodies[body.parent], views)
        if self._small:
            tips = (self._tip_prev, tip) if (tip is not None and self._tip_prev is not None) else None
            track_small(c, list(self._small.values()), self._detect(obs, views), obs.t, dT_ee if on else None, tips)
        self._maybe_reacquire(obs, views)
        self._update_held(tip, on)  # after re-acquisition: a body re-painted in the jaws is carried next frame
        self._ee = ee
        self._tip_prev = tip
        self._t = obs.t
        return self._result(obs)

    def detected_owners(self) -> set[Owner]:
        """The (object, part) bodies followed by detection (too small to register) since the last reset."""
        return set(self._small)

    # --- bodies -----------------------------------------------------------------------------------
    def _attach(self, el: Element, views: list[ViewData]) -> None:
        """Put element ``el`` on its body (created from its clouds when new)."""
        obj, part = el.owner
        cloud = getattr(el, "cloud", None)
        obj_cloud = getattr(el, "object_cloud", None)
        if cloud is None or len(cloud) == 0:
            cloud, obj_cloud = (obj_cloud, None) if obj_cloud is not None and not part else (None, None)
        self._local[el.id] = el.points.copy()
        if cloud is None:
            self._body_of[el.id] = None
            return
        owner = (obj, part)
        if self._attach_small(el, owner, cloud):
            return
        parent: Owner | None = None
        if part and obj_cloud is not None and len(obj_cloud) and obj_cloud is not cloud:
            parent = (obj, "")
            known = self._bodies.get(parent)
            if known is None or (known.lost and not relocate(self.config, known, obj_cloud, views, self._plane)):
                self._bodies[parent] = self._new_body(parent, obj_cloud, views, None)
                for b in self._bodies.values():  # the parts' poses relative to the new model frame
                    b.rel = (None if b.lost else b.T) if b.parent == parent else b.rel
        body = self._bodies.get(owner)
        if body is None or body.model is None or body.lost or not np.allclose(body.T, np.eye(4)):
            keep = body.elements if body is not None else []
            body = self._bodies[owner] = self._new_body(owner, cloud, views, parent)
            body.rel = invert(self._bodies[parent].T) if parent is not None and not self._bodies[parent].lost else None
            body.elements = [i for i in keep if i != el.id]
            for i in body.elements:  # the others' points were in the old model frame
                self._local[i] = self._last[i].copy()
        body.elements.append(el.id)
        self._body_of[el.id] = owner if body.model is not None else None

    def _attach_small(self, el: Element, owner: Owner, cloud: np.ndarray) -> bool:
        """Put element ``el`` on a small body followed by detection, when the tracker has a segmenter and the
        body's cloud is too small to register (and it is not a part of an object with a registrable element);
        False otherwise. Its points are kept relative to the body's reference point (the centroid of the
        points of the first element painted on it)."""
        c = self.config
        if self._segmenter is None or (owner[1] and owner[0] in self._registrable):
            return False
        sb = self._small.get(owner)
        if sb is None:
            pts = model_points(cloud, c, self._plane)
            if not len(pts) or not is_small(pts, c):
                return False
            sb = self._small[owner] = SmallBody(owner, ElementSpec(el.name, owner[0], owner[1], el.kind),
                                                max(principal_extent(pts), 2 * c.voxel), el.points.mean(axis=0))
        self._local[el.id] = el.points - sb.position
        if el.id not in sb.elements:
            sb.elements.append(el.id)
        self._body_of[el.id] = owner
        return True

    def _detect(self, obs: Observation, views: list[ViewData]) -> dict[str, ViewDetections]:
        """This frame's anonymous detections of the small bodies (see depth_detect.detect)."""
        if not self._small or self._segmenter is None:
            return {}
        usable, bodies = {v.name for v in views}, list(self._small.values())
        keys = [k for k, v in obs.views.items() if getattr(v.camera, "name", None) in usable]
        return detect(self._segmenter, obs, keys, [b.spec for b in bodies], self.config.detect_min_pixels,
                      max(b.extent for b in bodies))

    def _new_body(self, owner: Owner, cloud: np.ndarray, views: list[ViewData], parent: Owner | None) -> BodyState:
        c = self.config
        try:
            model = RigidBody(cloud, c.voxel, self._plane, c.plane_band, c.min_points, c.max_model_points)
        except CamError as exc:
            log.info("body %s/%s cannot be tracked: %s", owner[0], owner[1] or "*", exc)
            return BodyState(owner, None, parent, lost=True)
        seen = support(model.points, views, c.depth_tol, c.max_depth)
        if c.support_chroma > 0:  # the colours its points are seen in now, at paint time (depth_body.model_chroma)
            model.chroma = model_chroma(model.points, views, c.depth_tol, c.max_depth, c.chroma_min_sum,
                                       c.support_chroma)
        return BodyState(owner, model, parent, ref_seen=max(seen.seen, c.min_seen), seen_views=seen.views,
                         painted=self._frame, small=is_small(model.points, c))

    def _ordered_bodies(self) -> list[Owner]:
        """Whole objects first, then held parts (their motion is known best), then the other parts."""
        return sorted(self._bodies, key=lambda o: (self._bodies[o].parent is not None, not self._bodies[o].held))

    def _nearest_moved(self, body: BodyState, moves: dict[Owner, np.ndarray], k: int) -> list[np.ndarray]:
        """This frame's motions of up to ``k`` other parts of ``body``'s object that moved it, nearest first."""
        if body.model is None or k <= 0:
            return []
        here = apply(body.T, body.model.centre[None])[0]
        cands = []
        for o, m in moves.items():
            other = self._bodies[o]
            if o[0] != body.owner[0] or not o[1] or o == body.owner or other.model is None or not moves_body(m, body):
                continue
            cands.append((float(np.linalg.norm(apply(other.T, other.model.centre[None])[0] - here)), m))
        return [m for _, m in sorted(cands, key=lambda x: x[0])[:k]]

    def _update_held(self, tip: np.ndarray | None, on: bool) -> None:
        """Which bodies the end effector holds: gripper or suction ``on`` and a model point within ``held_distance``
        of the ``tip`` (3,) world (None: no robot state)."""
        for body in self._bodies.values():
            if body.model is None or tip is None or not on:
                body.held = False
                continue
            P = apply(body.T_search if body.lost else body.T, body.model.points)
            body.held = bool(np.min(np.linalg.norm(P - tip, axis=1)) <= self.config.held_distance)
        for sb in self._small.values():
            sb.held = tip is not None and on and bool(
                np.linalg.norm(sb.position - tip) <= self.config.held_distance + sb.extent / 2)

    # --- re-acquisition ---------------------------------------------------------------------------
    def _maybe_reacquire(self, obs: Observation, views: list[ViewData]) -> None:
        c = self.config
        for eid in self._order:
            owner = self._body_of.get(eid, "robot")
            if owner == "robot" or eid in self._anchors or owner in self._small:
                continue  # small bodies are re-acquired by their anonymous detections, not by name
            body = self._bodies.get(owner) if owner is not None else None
            if body is not None and not body.lost:
                continue
            frames = body.lost_frames if body is not None else self._stale_count(eid)
            if self._reacquire is None or frames <= c.reacquire_after:
                continue
            if body is not None:
                body.lost_frames = 0  # retry only after another period
            else:
                self._unbodied[eid] = 0
            old = self._elements[eid]
            new = self._reacquire(obs, Element(old.id, old.name, old.kind, self._last[eid].copy(), old.owner,
                                               old.color))
            if new is None or stood_in(old, new):  # a part re-painted from its whole object: stays stale
                continue
            if new.id != eid:
                raise PerceptionError(f"reacquire hook returned element {new.id} for element {eid}")
            if body is not None and eid in body.elements and keep_known(c, body, self._bodies, new, views, self._plane):
                self._fresh.add(eid)  # a weak re-paint: the known model, relocated, keeps the element on it
                continue
            if body is not None and new.support is not None and new.support.weak() and \
                    hidden_where_it_was(c, body, views):
                continue  # a weak re-paint of a body only hidden where it was is no evidence it moved: stale
            self._elements[eid] = new
            self._last[eid] = new.points.copy()
            if body is not None and eid in body.elements:
                body.elements.remove(eid)
            self._attach(new, views)
            self._fresh.add(eid)

    def _stale_count(self, eid: int) -> int:
        """Frames an element without a body has been stale (counted here, as it has no body)."""
        self._unbodied[eid] = self._unbodied.get(eid, 0) + 1
        return self._unbodied[eid]

    # --- views, plane, result ---------------------------------------------------------------------
    def _usable_views(self, obs: Observation) -> list[ViewData]:
        out = []
        for name, view in obs.views.items():
            try:
                data = ViewData(view)
            except CamError as exc:
                if name not in self._warned:
                    log.warning("depth tracker: view %r skipped: %s", name, exc)
                    self._warned.add(name)
                continue
            out.append(data)
        return out

    def _result(self, obs: Observation) -> TrackResult:
        points: dict[int, np.ndarray] = {}
        stale: dict[int, np.ndarray] = {}
        visible: dict[int, int] = {}
        support: dict[int, float] = {}  # small bodies (detected, not registered) report none
        for eid in self._order:
            if eid in self._anchors:
                points[eid], stale[eid], visible[eid] = self._anchors[eid].observe(obs)
                support[eid] = math.inf  # forward kinematics
                continue
            owner = self._body_of.get(eid)
            sb = self._small.get(owner) if owner is not None else None
            if sb is not None:
                if not sb.lost:
                    self._last[eid] = sb.position + self._local[eid]
                points[eid] = self._last[eid].copy()
                stale[eid] = np.full(len(points[eid]), sb.lost)
                visible[eid] = sb.seen_views
                continue
            body = self._bodies.get(owner) if owner is not None else None
            fresh = eid in self._fresh
            if body is not None and not body.lost:
                self._last[eid] = apply(body.T, self._local[eid])
                fresh = True
                ev = self._bodies[body.parent].last if body.on_parent and body.parent else body.last
                support[eid] = float(ev.seen) if ev is not None else 0.0  # model points seen
            points[eid] = self._last[eid].copy()
            stale[eid] = np.full(len(points[eid]), not fresh)
            visible[eid] = body.seen_views if (body is not None and not body.lost) else 0
        self._fresh.clear()
        return TrackResult(obs.t, points, stale, visible, support)


def _ee_pose(obs: Observation) -> np.ndarray | None:
    return None if obs.robot is None else np.asarray(obs.robot.ee_pose, dtype=np.float64)


def _tool(obs: Observation, ee: np.ndarray, tip: np.ndarray, radius: float, margin: float) -> tuple:
    """The end-effector's exclusion cylinder: ``(tip, axis into the tool, radius, margin)``; the radius
    grows to hold the named end-effector points (a gripper's jaws) with 1.5 cm to spare."""
    assert obs.robot is not None
    axis = -ee[:3, 2]
    for p in obs.robot.ee_points.values():
        rel = np.asarray(p, dtype=np.float64).reshape(3) - tip
        radius = max(radius, float(np.linalg.norm(rel - (rel @ axis) * axis)) + 0.015)
    return tip, axis, radius, margin
