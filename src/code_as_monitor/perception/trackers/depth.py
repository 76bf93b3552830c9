"""Depth tracker: each element's object or part followed in 3-D by registering its painted cloud to the
current depth images of all views (small_gicp), with no per-frame segmentation and no simulator pose.

Bodies. Elements are grouped by owner ``(object, part)``; each group is one rigid *body* whose model is
the owner's cloud at paint time (``Element.cloud``: the part's mask for a part, the instance's for a
whole object). A part element whose element also carries the whole object's cloud
(``Element.object_cloud``) gets that object as its *parent* body: the parent is registered first and
its motion is one of the part's guesses, so a part rigid with its object (a block's top, a teapot's
lid) moves with the well-constrained whole, while a part that moves on its own (a drawer handle on a
prismatic drawer, a rope bead) is registered from its own cloud and wins by its own evidence.
An element's points move with its body's pose: ``p_now = T_body @ p_painted``.

Per frame and body:

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
   result with the most evidence wins;
4. no passing result: the body is *lost* this frame and its elements are stale (they keep their last
   good points; nothing is guessed). A lost body keeps being searched from its last pose (and, while
   held, from where the end-effector carried it). After ``reacquire_after`` lost frames the hook set by
   :meth:`set_reacquire` re-segments its elements (the agent re-runs the painter); the returned
   elements' clouds become the body's new model.

Elements owned by the robot follow forward kinematics (:class:`.base.KinematicAnchor`). An element
without a cloud (not built from masks) cannot be registered: it is stale until the hook re-paints it.
A view whose depth or camera is unusable is skipped for the frame with a logged warning.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import CamError, PerceptionError
from code_as_monitor.core.observation import Observation
from code_as_monitor.perception.trackers.base import (
    DepthTrackerConfig,
    KinematicAnchor,
    Tracker,
    TrackResult,
    views_containing,
)
from code_as_monitor.perception.trackers.depth_body import (
    Plane,
    RigidBody,
    Support,
    ViewData,
    apply,
    crop_scene,
    invert,
    register,
    support,
)

log = logging.getLogger(__name__)

Owner = tuple[str, str]


@dataclass
class _Body:
    """Tracking state of one rigid body (an object or a part)."""

    owner: Owner
    model: RigidBody | None
    parent: Owner | None = None
    T: np.ndarray = field(default_factory=lambda: np.eye(4))  # last good pose, model frame -> world
    T_prev: np.ndarray = field(default_factory=lambda: np.eye(4))  # the good pose before it
    T_search: np.ndarray = field(default_factory=lambda: np.eye(4))  # where a lost body is searched
    ref_seen: int = 1  # model points seen at paint time
    lost: bool = False
    lost_frames: int = 0
    lost_before: int = 0  # lost_frames before this frame's success (an overlap loss continues the count)
    moved: float = 0.0  # metres the last good step moved the model's centre
    held: bool = False  # within held_distance of the tip with the gripper on, last frame
    seen_views: int = 0
    last: Support | None = None  # evidence of the last good pose, in its frame
    painted: int = 0  # frame counter value when the model was painted (later = more recent evidence)
    elements: list[int] = field(default_factory=list)


class DepthTracker(Tracker):
    """Streaming multi-view depth-registration tracker (see the module docstring)."""

    def __init__(self, config: DepthTrackerConfig | None = None) -> None:
        super().__init__()
        self.config = config or DepthTrackerConfig()
        self._order: list[int] = []
        self._elements: dict[int, Element] = {}
        self._anchors: dict[int, KinematicAnchor] = {}
        self._bodies: dict[Owner, _Body] = {}
        self._local: dict[int, np.ndarray] = {}  # element id -> (k, 3) model-frame points
        self._body_of: dict[int, Owner | None] = {}  # None: no cloud, never registered
        self._last: dict[int, np.ndarray] = {}  # element id -> last reported points
        self._plane: Plane | None = None
        self._ee: np.ndarray | None = None  # (4, 4) end-effector pose at the previous frame
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
        self._local.clear()
        self._body_of.clear()
        self._unbodied.clear()
        self._fresh.clear()
        self._last = {el.id: el.points.copy() for el in elements}
        views = self._usable_views(obs)
        self._plane = self._fit_plane(views)
        for el in elements:
            if el.owner[0] in self.config.kinematic_owners:
                self._anchors[el.id] = KinematicAnchor(obs, el)
            else:
                self._attach(el, views)
        self._ee = _ee_pose(obs)
        self._t = obs.t

    def step(self, obs: Observation) -> TrackResult:
        c = self.config
        self._frame += 1
        views = self._usable_views(obs)
        ee = _ee_pose(obs)
        dT_ee = ee @ invert(self._ee) if (ee is not None and self._ee is not None) else None
        on = obs.robot is not None and float(obs.robot.gripper) >= 0.5
        tool = None
        if ee is not None and c.tool_radius > 0:
            tip = _tip(obs)
            tool = (tip, -ee[:3, 2], c.tool_radius, c.tool_margin)
        dt = obs.t - self._t if self._t is not None else 0.0
        moves: dict[Owner, np.ndarray] = {}  # body -> this frame's rigid motion (for its parts)
        for owner in self._ordered_bodies():
            body = self._bodies[owner]
            related = []
            if body.parent is not None:  # parts of the same object that moved, then the whole object
                related = [m for o, m in moves.items() if o[0] == owner[0] and o[1] and _moves(m, body)]
                if body.parent in moves:
                    related.append(moves[body.parent])
            before = body.T.copy()
            self._track_body(body, views, dT_ee if (on and body.held) else None, related, dt, tool)
            if not body.lost:
                moves[owner] = body.T @ invert(before)
        self._resolve_overlaps()
        self._update_held(obs, on)
        self._ee = ee
        self._t = obs.t
        self._maybe_reacquire(obs, views)
        return self._result(obs)

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
        parent: Owner | None = None
        if part and obj_cloud is not None and len(obj_cloud) and obj_cloud is not cloud:
            parent = (obj, "")
            if parent not in self._bodies or self._bodies[parent].lost:
                self._bodies[parent] = self._new_body(parent, obj_cloud, views, None)
        body = self._bodies.get(owner)
        if body is None or body.model is None or body.lost or not np.allclose(body.T, np.eye(4)):
            keep = body.elements if body is not None else []
            body = self._bodies[owner] = self._new_body(owner, cloud, views, parent)
            body.elements = [i for i in keep if i != el.id]
            for i in body.elements:  # the others' points were in the old model frame
                self._local[i] = self._last[i].copy()
        body.elements.append(el.id)
        self._body_of[el.id] = owner if body.model is not None else None

    def _new_body(self, owner: Owner, cloud: np.ndarray, views: list[ViewData], parent: Owner | None) -> _Body:
        c = self.config
        try:
            model = RigidBody(cloud, c.voxel, self._plane, c.plane_band, c.min_points, c.max_model_points)
        except CamError as exc:
            log.info("body %s/%s cannot be tracked: %s", owner[0], owner[1] or "*", exc)
            return _Body(owner, None, parent, lost=True)
        seen = support(model.points, views, c.depth_tol, c.max_depth)
        return _Body(owner, model, parent, ref_seen=max(seen.seen, c.min_seen), seen_views=seen.views,
                     painted=self._frame)

    def _ordered_bodies(self) -> list[Owner]:
        """Whole objects first, then held parts (their motion is known best), then the other parts."""
        return sorted(self._bodies, key=lambda o: (self._bodies[o].parent is not None, not self._bodies[o].held))

    def _track_body(self, body: _Body, views: list[ViewData], dT_ee: np.ndarray | None,
                    related: list[np.ndarray], dt: float, tool: tuple | None) -> None:
        c = self.config
        if body.model is None:
            return
        found: tuple[np.ndarray, Support] | None = None
        if views and not body.lost and dT_ee is None and body.last is not None:
            # At rest, or (a part) carried along rigidly by its object: no registration needed.
            found = self._unmoved(body, views, related[-1] if body.parent is not None and related else None)
        guesses = self._guesses(body, dT_ee, related, dt)
        if views and found is None:
            boxes = [apply(T, body.model.box) for T in guesses]
            scene = crop_scene(views, boxes, c.margin_px, c.box_margin, c.max_depth,
                               None if body.model.in_plane else self._plane, c.plane_band, tool)
            if len(scene) >= c.min_points:
                found = self._search(body, views, scene, guesses)
        if found is None:
            body.lost = True
            body.lost_frames += 1
            body.seen_views = 0
            body.T_search = dT_ee @ body.T_search if dT_ee is not None else body.T_search
            return
        T, sup = found
        body.last = sup
        body.moved = float(np.linalg.norm(apply(T, body.model.centre[None]) - apply(body.T, body.model.centre[None])))
        body.T_prev, body.T, body.T_search = body.T, T, T
        body.lost, body.lost_before, body.lost_frames, body.seen_views = False, body.lost_frames, 0, sup.views

    def _guesses(self, body: _Body, dT_ee: np.ndarray | None, related: list[np.ndarray],
                 dt: float) -> list[np.ndarray]:
        """Candidate poses, most likely first: carried by the end-effector; moved like the parts of the same
        object already registered this frame (a drawer with its handle) and like the whole object; where
        it was; at constant velocity; falling; dropped from the gripper."""
        c = self.config
        T0 = body.T_search if body.lost else body.T
        out: list[np.ndarray] = []
        if dT_ee is not None:
            out.append(dT_ee @ T0)
        for M in related:  # the motion as estimated, and its translation of this body's centre alone
            out.append(M @ T0)
            ctr = apply(T0, body.model.centre[None])[0] if body.model is not None else np.zeros(3)
            shifted = T0.copy()
            shifted[:3, 3] += apply(M, ctr[None])[0] - ctr
            out.append(shifted)
        out.append(T0)
        if not body.lost and body.moved > c.moving:
            step = body.T @ invert(body.T_prev)
            out.append(step @ T0)
            fall = step @ T0
            fall[2, 3] -= c.gravity * dt * dt
            out.append(fall)
        if dT_ee is not None:  # released: a free-fall step below where the gripper took it
            drop = dT_ee @ T0
            drop[2, 3] -= 0.5 * c.gravity * dt * dt
            out.append(drop)
        return _distinct(out, body.model.radius if body.model is not None else 0.05)

    def _unmoved(self, body: _Body, views: list[ViewData],
                 parent_move: np.ndarray | None) -> tuple[np.ndarray, Support] | None:
        """The last pose (moved with the parent object when given), when the new frame sees the body there
        as well as the last frame saw it (no registration: most bodies are at rest most of the time, and a
        part mostly moves with its object)."""
        c = self.config
        last = body.last
        assert body.model is not None and last is not None
        T = body.T.copy() if parent_move is None else parent_move @ body.T
        sup = support(apply(T, body.model.points), views, c.depth_tol, c.max_depth)
        if (sup.seen >= c.unmoved_seen * last.seen
                and sup.contradicted <= last.contradicted + max(2, 0.02 * last.seen)
                and sup.residual <= last.residual + c.unmoved_residual):
            return T, last if parent_move is None else sup  # at rest the evidence stays the registration's
        return None

    def _search(self, body: _Body, views: list[ViewData], scene: np.ndarray,
                guesses: list[np.ndarray]) -> tuple[np.ndarray, Support] | None:
        """Register from each guess in order (most likely first), first with the finest correspondence
        distance only (a guess already close must not be pulled off by a neighbour's surface), then, when
        none passes, coarse to fine. The search stops at a passing result with as much evidence as the last
        frame had; otherwise the passing result with the most evidence wins (a static cabinet frame does
        not follow its drawer: the drawer's motion passes for it but fits worse than staying put)."""
        import small_gicp

        c = self.config
        model = body.model
        assert model is not None
        source = small_gicp.voxelgrid_sampling(scene, model.voxel)
        if source.size() > 2 * c.max_model_points:  # a crop bigger than the body: a coarser grid
            coarser = model.voxel * np.sqrt(source.size() / (2 * c.max_model_points))
            source = small_gicp.voxelgrid_sampling(scene, coarser)
        if c.registration == "GICP":
            small_gicp.estimate_covariances(source, num_neighbors=10)
        need = max(c.min_seen, int(c.min_seen_frac * body.ref_seen))
        fine = c.max_correspondence[-1:]
        at_guess: list[Support | None] = [None] * len(guesses)
        best: tuple[np.ndarray, Support] | None = None
        for rounds in (fine, c.max_correspondence) if len(c.max_correspondence) > 1 else (fine,):
            for i, T0 in enumerate(guesses):
                T, _ = register(model, source, T0, c.registration, rounds, c.max_iterations, c.min_information)
                sup = support(apply(T, model.points), views, c.depth_tol, c.max_depth)
                if at_guess[i] is None:
                    at_guess[i] = support(apply(T0, model.points), views, c.depth_tol, c.max_depth)
                g = at_guess[i]
                assert g is not None
                if _score(g) > _score(sup):  # the registration made a fitting guess worse: keep the guess
                    T, sup = T0, g
                if sup.seen < need or sup.contradiction > c.max_contradiction:
                    continue
                if best is None or _score(sup) > _score(best[1]):
                    best = (T, sup)
                if self._as_good_as_last(body, sup):
                    return best
            if best is not None:
                return best
        return best

    def _as_good_as_last(self, body: _Body, sup: Support) -> bool:
        """Whether ``sup`` is as much evidence as the body's last good pose had (the search may stop)."""
        last = body.last
        if last is None:
            return False
        return (sup.seen >= self.config.unmoved_seen * last.seen
                and sup.contradicted <= last.contradicted + max(2, 0.01 * last.seen))

    def _resolve_overlaps(self) -> None:
        """Two bodies of different objects cannot occupy the same space: when one's model points mostly
        lie on the other's surface (an identical block slid onto its neighbour), the body painted
        longer ago, or on a tie the one that moved further this frame, is lost."""
        c = self.config
        live = [b for b in self._bodies.values() if b.model is not None and not b.lost]
        centres = [apply(b.T, b.model.centre[None])[0] for b in live]  # type: ignore[union-attr]
        for i, a in enumerate(live):
            for j in range(i + 1, len(live)):
                b = live[j]
                if a.owner[0] == b.owner[0] or a.lost or b.lost:
                    continue
                ra, rb = a.model.radius, b.model.radius  # type: ignore[union-attr]
                if np.linalg.norm(centres[i] - centres[j]) > ra + rb:
                    continue
                small, big = (a, b) if len(a.model.points) <= len(b.model.points) else (b, a)  # type: ignore[union-attr]
                P = apply(invert(big.T) @ small.T, small.model.points)  # type: ignore[union-attr]
                _, d2 = big.model.tree.batch_nearest_neighbor_search(P)  # type: ignore[union-attr]
                if np.mean(np.sqrt(np.asarray(d2)) <= c.depth_tol) < c.max_overlap:
                    continue
                if a.painted != b.painted:
                    loser = a if a.painted < b.painted else b
                else:
                    loser = a if a.moved >= b.moved else b
                log.debug("bodies %s and %s overlap: %s lost", a.owner, b.owner, loser.owner)
                loser.T, loser.T_search = loser.T_prev, loser.T_prev
                loser.lost, loser.lost_frames, loser.seen_views = True, loser.lost_before + 1, 0

    def _update_held(self, obs: Observation, on: bool) -> None:
        tip = _tip(obs) if obs.robot is not None else None
        for body in self._bodies.values():
            if body.model is None or tip is None or not on:
                body.held = False
                continue
            P = apply(body.T_search if body.lost else body.T, body.model.points)
            body.held = bool(np.min(np.linalg.norm(P - tip, axis=1)) <= self.config.held_distance)

    # --- re-acquisition ---------------------------------------------------------------------------
    def _maybe_reacquire(self, obs: Observation, views: list[ViewData]) -> None:
        c = self.config
        for eid in self._order:
            owner = self._body_of.get(eid, "robot")
            if owner == "robot" or eid in self._anchors:
                continue
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
            if new is None:
                continue
            if new.id != eid:
                raise PerceptionError(f"reacquire hook returned element {new.id} for element {eid}")
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

    def _fit_plane(self, views: list[ViewData]) -> Plane | None:
        """The dominant plane of the views' depth (RANSAC), when it holds at least a quarter of the pixels."""
        from code_as_monitor.perception.segmenters.color import fit_plane_ransac

        c = self.config
        if c.plane_band <= 0 or not views:
            return None
        P = np.concatenate([_lift_all(v, c.max_depth, 7) for v in views])
        if len(P) < 50:
            return None
        fit = fit_plane_ransac(P, 0.5 * c.plane_band, 64, np.random.default_rng(0))
        if fit is None:
            return None
        n, d = fit
        if (np.abs(P @ n + d) <= c.plane_band).mean() < 0.25:
            return None
        return (n, d) if n @ views[0].t_wc + d > 0 else (-n, -d)

    def _result(self, obs: Observation) -> TrackResult:
        points: dict[int, np.ndarray] = {}
        stale: dict[int, np.ndarray] = {}
        visible: dict[int, int] = {}
        for eid in self._order:
            if eid in self._anchors:
                points[eid] = self._anchors[eid].points(obs)
                stale[eid] = np.zeros(len(points[eid]), dtype=bool)
                visible[eid] = views_containing(obs, points[eid])
                continue
            owner = self._body_of.get(eid)
            body = self._bodies.get(owner) if owner is not None else None
            fresh = eid in self._fresh
            if body is not None and not body.lost:
                self._last[eid] = apply(body.T, self._local[eid])
                fresh = True
            points[eid] = self._last[eid].copy()
            stale[eid] = np.full(len(points[eid]), not fresh)
            visible[eid] = body.seen_views if (body is not None and not body.lost) else 0
        self._fresh.clear()
        return TrackResult(obs.t, points, stale, visible)


def _moves(M: np.ndarray, body: _Body) -> bool:
    """Whether the rigid motion ``M`` (4, 4) moves ``body``'s model centre by more than 1 mm."""
    if body.model is None:
        return False
    c = apply(body.T, body.model.centre[None])
    return bool(np.linalg.norm(apply(M, c) - c) > 1e-3)


def _score(s: Support) -> float:
    """Evidence of a pose: points seen, a contradicted point costing three seen ones."""
    return s.seen - 3.0 * s.contradicted


def _distinct(poses: list[np.ndarray], radius: float) -> list[np.ndarray]:
    """``poses`` without near-duplicates (within 2 mm at the body's extent), first occurrence kept."""
    out: list[np.ndarray] = []
    for T in poses:
        if any(np.abs(T[:3, 3] - S[:3, 3]).max() < 0.002 and np.abs(T[:3, :3] - S[:3, :3]).max() * radius < 0.002
               for S in out):
            continue
        out.append(T)
    return out


def _lift_all(view: ViewData, max_depth: float, stride: int) -> np.ndarray:
    """World points (N, 3) of every ``stride``-th pixel (both axes) of a view with a valid reading."""
    roi = view.depth[::stride, ::stride]
    vv, uu = np.nonzero((roi > 0) & (roi <= max_depth))
    z = roi[vv, uu].astype(np.float64)
    pc = np.stack([(uu * stride - view.cx) * z / view.fx, (vv * stride - view.cy) * z / view.fy, z], axis=1)
    return pc @ view.R_wc.T + view.t_wc


def _ee_pose(obs: Observation) -> np.ndarray | None:
    return None if obs.robot is None else np.asarray(obs.robot.ee_pose, dtype=np.float64)


def _tip(obs: Observation) -> np.ndarray:
    assert obs.robot is not None
    p = obs.robot.ee_points.get("tip")
    return np.asarray(p if p is not None else obs.robot.ee_pose[:3, 3], dtype=np.float64).reshape(3)
