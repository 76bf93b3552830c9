"""Multi-view pyramidal Lucas-Kanade element tracker, lifted to 3-D with depth and fused across views.

Per frame and per view (all element points of a view in one call):

1. one forward LK call (previous -> current grayscale) and one backward call (current -> previous)
   over all the view's points. OpenCV's Python binding cannot take the pyramids of
   ``cv2.buildOpticalFlowPyramid`` as inputs (opencv/opencv#4777), so each call builds them itself;
   one call per direction per view keeps that to the minimum the binding allows;
2. a track is lost in that view when LK fails, the forward-backward error exceeds
   ``fb_threshold_px``, it comes within ``border_px`` of the border, its pixel has no depth, or the
   depth reading jumped more than ``max_depth_jump`` since the previous frame (it slid onto another
   surface, or something passed in front);
3. surviving pixels are lifted with ``geometry.backproject_pixels`` and shifted by the per-view
   *anchor offset* (below) to give that view's estimate of the 3-D point.

Anchors: each element point is followed through ``anchors`` tracked pixels per view: its own pixel
and surface pixels within ``anchor_radius`` (3-D) of it, each carrying its world-frame offset to the
point. A view's estimate of the point is the median over its surviving anchors, so the point keeps
being observed while its own pixel is covered (a suction cup sitting on a block's top face) as long
as some of the object's surface near it is seen. A point is re-seeded in a view when fewer than
``reseed_below`` of its anchors survive there.

Fusion: the mean (or median) of the views' estimates. A point no view observed is *stale*: it keeps
its last position. For line and surface elements with ``rigid`` on, a rigid transform (Kabsch) from
the element's reference shape (its points at reset / re-acquisition) to the fused estimates of its
observed points is fitted when at least ``rigid_min_points`` are observed and the RMS residual is at
most ``rigid_max_residual``; it is applied to all the element's points, which are then all fresh (a
partially occluded surface keeps its shape). Otherwise observed points take their fused estimates
and the others stay stale.

Seeding (at reset, and every frame for a fresh point a view is not tracking: re-acquisition from
another view): the point is projected into the view. It is visible there when the depth reading at
the projection lies at most ``occlusion_tol`` behind and at most ``occlusion_tol + inside_tol`` in
front of the point (``inside_tol`` admits points inside an object, such as a fitted line's axis).
Otherwise the nearest pixel within ``seed_search_px`` whose lifted point is within ``occlusion_tol``
of the 3-D point is used (element corners lie on object boundaries). The tracked pixel is the
*anchor*; ``offset = point - lift(anchor)`` is stored (world frame) and added to later lifts.

Re-acquisition of points stale in every view: when an element has had a stale point for more than
``reacquire_after`` frames, the hook set by :meth:`set_reacquire` (the agent re-runs the painter) is
called; a returned element replaces the points and is re-seeded, ``None`` waits another period.

Elements owned by the robot follow forward kinematics (:class:`.anchor.KinematicAnchor`). The per-view state,
the rigid fit and the fusion helpers live in :mod:`.lk_state`.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from code_as_monitor.core.elements import Element, ElementKind
from code_as_monitor.core.errors import PerceptionError
from code_as_monitor.core.observation import Observation, View
from code_as_monitor.geometry.transforms import kabsch
from code_as_monitor.perception.trackers.anchor import KinematicAnchor
from code_as_monitor.perception.trackers.base import LKTrackerConfig, Tracker, TrackResult
from code_as_monitor.perception.trackers.lk_state import (
    ViewState,
    cam_z,
    chroma_at,
    chroma_kept,
    gray_of,
    inside,
    nanmean,
    nanmedian_axis,
    slots,
    views_agree,
)

_RIGID_KINDS = (ElementKind.LINE, ElementKind.SURFACE)


class LKTracker(Tracker):
    """Streaming multi-view LK tracker (see the module docstring)."""

    def __init__(self, config: LKTrackerConfig | None = None) -> None:
        super().__init__()
        from code_as_monitor.geometry import backproject_pixels

        self._lift = backproject_pixels
        self.config = config or LKTrackerConfig()
        c = self.config
        self._win = (c.window, c.window)
        self._criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, c.iterations, c.epsilon)
        self._K = c.anchors
        self._tip: np.ndarray | None = None  # end-effector tip at the previous frame, world
        self._elements: dict[int, Element] = {}
        self._anchors: dict[int, KinematicAnchor] = {}
        self._views: dict[str, ViewState] = {}
        self._slices: dict[int, slice] = {}
        self.P = np.zeros((0, 3))  # (M, 3) current points, world metres
        self.ref = np.zeros((0, 3))  # (M, 3) reference shape for the rigid fit
        self.stale = np.zeros(0, dtype=bool)
        self._stale_frames: dict[int, int] = {}
        self._support: dict[int, float] = {}  # element id -> anchors behind its fused points, last frame
        r = c.seed_search_px
        offs = np.arange(-r, r + 1, max(1, r // 3)) if r > 0 else np.zeros(1)
        du, dv = np.meshgrid(offs, offs)
        order = np.argsort(du.ravel() ** 2 + dv.ravel() ** 2, kind="stable")
        self._search = np.stack([du.ravel()[order], dv.ravel()[order]], axis=1).astype(np.float64)
        ra = c.anchor_search_px
        step = max(1, ra // 5)
        offs = np.arange(-ra, ra + 1, step)
        du, dv = np.meshgrid(offs, offs)
        self._ring = np.stack([du.ravel(), dv.ravel()], axis=1).astype(np.float64)

    # --- public API -------------------------------------------------------------------------------
    def reset(self, obs: Observation, elements: list[Element]) -> None:
        self._anchors.clear()
        self._views.clear()
        self._support = {}
        tracked = []
        for el in elements:
            if el.owner[0] in self.config.kinematic_owners:
                self._anchors[el.id] = KinematicAnchor(obs, el)
            else:
                tracked.append(el)
        self._order = [el.id for el in elements]
        self._tip = obs.tip
        self._elements = {el.id: el for el in elements}
        self._layout(tracked)
        for name, view in obs.views.items():
            st = self._views[name] = ViewState(len(self.P) * self._K)
            st.gray = gray_of(view)
            self._seed(view, st, np.ones(len(self.P), dtype=bool))
            st.make_key()

    def step(self, obs: Observation) -> TrackResult:
        c = self.config
        m, K = len(self.P), self._K
        for name in [n for n in self._views if n not in obs.views]:
            del self._views[name]  # a view that dropped out is re-seeded when it returns
        est = np.full((len(obs.views), m * K, 3), np.nan)  # per view, per anchor slot
        tip = obs.tip
        ee_delta = tip - self._tip if (tip is not None and self._tip is not None) else None
        self._tip = tip
        for k, (name, view) in enumerate(obs.views.items()):
            gray = gray_of(view)
            st = self._views.get(name)
            if st is None:
                st = self._views[name] = ViewState(m * K)
            st.gray = gray
            if st.active.any() and st.key is not None:
                self._track(view, st, est[k], ee_delta)
        per_view = nanmedian_axis(est.reshape(len(obs.views), m, K, 3), axis=2)  # (V, M, 3)
        observed = np.isfinite(per_view[:, :, 0])  # (V, M)
        ok = observed.any(axis=0) & views_agree(per_view, observed, c.max_view_disagreement)
        if c.fusion == "median":
            fused = np.full((m, 3), np.nan)
            fused[ok] = np.nanmedian(per_view[:, ok], axis=0)
        else:
            fused = nanmean(per_view, observed)
        self._update_points(fused, ok)
        visible = {eid: int(observed[:, sl].any(axis=1).sum()) for eid, sl in self._slices.items()}
        anchors = np.where(ok, np.isfinite(est[:, :, 0]).reshape(len(obs.views), m, K).sum(axis=(0, 2)), 0)
        self._support = {eid: float(anchors[sl].sum()) for eid, sl in self._slices.items()}
        fresh = ~self.stale
        for name, view in obs.views.items():
            st = self._views[name]
            alive = st.active.reshape(m, K).sum(axis=1) if m else np.zeros(0, dtype=int)
            self._seed(view, st, fresh & (alive < max(1.0, c.reseed_below * K)))
            if st.rekey:
                st.make_key()
        self._maybe_reacquire(obs)
        return self._result(obs, visible)

    # --- internals --------------------------------------------------------------------------------
    def _layout(self, tracked: list[Element]) -> None:
        self._slices, start = {}, 0
        for el in tracked:
            self._slices[el.id] = slice(start, start + len(el.points))
            start += len(el.points)
        pts = [el.points for el in tracked]
        self.P = np.concatenate(pts).astype(np.float64) if pts else np.zeros((0, 3))
        self.ref = self.P.copy()
        self.stale = np.zeros(len(self.P), dtype=bool)
        self._stale_frames = {el.id: 0 for el in tracked}

    def _track(self, view: View, st: ViewState, est: np.ndarray, ee_delta: np.ndarray | None = None) -> None:
        """LK key frame -> current and back for the view's active points; writes estimates (M, 3) into ``est``.

        With ``ee_delta`` (the tip's motion since the last frame, world metres), anchors near the tip are
        also tracked from the guess "moved with the end-effector"; per anchor the hypothesis with the
        smaller forward-backward error wins.
        """
        c = self.config
        idx = np.flatnonzero(st.active)
        p0 = st.key_uv[idx].reshape(-1, 1, 2)
        guesses = [st.uv[idx].astype(np.float32)]
        near = np.zeros(len(idx), dtype=bool)
        if ee_delta is not None and c.ee_prior_radius > 0 and np.linalg.norm(ee_delta) > 1e-3 and self._tip is not None:
            xyz = st.xyz[idx]
            near = np.isfinite(xyz[:, 0]) & (np.linalg.norm(xyz - (self._tip - ee_delta), axis=1) <= c.ee_prior_radius)
            if near.any():
                moved, z = view.camera.project(np.where(near[:, None], xyz + ee_delta, xyz))
                g = np.where((near & (z > 0))[:, None] & np.isfinite(moved), moved, guesses[0]).astype(np.float32)
                guesses.append(g)
        kw = {
            "winSize": self._win, "maxLevel": c.levels, "criteria": self._criteria,
            "minEigThreshold": c.min_eig, "flags": cv2.OPTFLOW_USE_INITIAL_FLOW,
        }
        best_p1 = None
        best_fb = np.full(len(idx), np.inf)
        for guess in guesses:
            p1, s1, _ = cv2.calcOpticalFlowPyrLK(st.key, st.gray, p0, guess.reshape(-1, 1, 2).copy(), **kw)
            p0b, s2, _ = cv2.calcOpticalFlowPyrLK(st.gray, st.key, p1, p0.copy(), **kw)
            fb = np.linalg.norm(p0b.reshape(-1, 2) - p0.reshape(-1, 2), axis=1)
            fb = np.where((s1.ravel() == 1) & (s2.ravel() == 1), fb, np.inf)
            p1 = p1.reshape(-1, 2)
            if best_p1 is None:
                best_p1, best_fb = p1.copy(), fb
            else:
                better = fb < best_fb
                best_p1[better], best_fb[better] = p1[better], fb[better]
        p1, fb = best_p1, best_fb
        good = (fb <= c.fb_threshold_px) & inside(view, c.border_px, p1)
        good &= chroma_kept(st.chroma[idx], chroma_at(view.rgb, p1, c.chroma_min_sum), c.max_chroma_change)
        lifted, valid = self._lift(p1, view.depth, view.camera, c.max_depth)
        good &= valid
        z = np.where(valid, cam_z(view, np.nan_to_num(lifted)), np.nan)
        prev_z = st.z[idx]
        if len(guesses) > 1:  # a held object's depth follows the tip's motion along the optical axis (near it only)
            prev_z = prev_z + np.where(near, ee_delta @ view.camera.T_world_cam[:3, 2], 0.0)
        with np.errstate(invalid="ignore"):
            good &= (np.abs(z - prev_z) <= c.max_depth_jump) | (np.abs(z - st.z[idx]) <= c.max_depth_jump)
        gi = idx[good]
        est[gi] = lifted[good] + st.offset[gi]
        st.uv[gi] = p1[good]
        st.z[gi] = z[good]
        st.xyz[gi] = lifted[good]
        st.active[idx[~good]] = False
        if gi.size and np.abs(st.uv[gi] - st.key_uv[gi]).max() > c.rekey_px:
            st.rekey = True

    def _seed(self, view: View, st: ViewState, want: np.ndarray) -> None:
        """Start tracking the points ``want`` (M,) bool in ``view`` where they are visible.

        Slot 0 of a point is its own pixel (or the nearest within ``seed_search_px`` seeing it); the
        other slots are surface pixels within ``anchor_radius`` of it, spread over the search window.
        """
        idx = np.flatnonzero(want)
        if idx.size == 0:
            return
        c, K = self.config, self._K
        P = self.P[idx]
        uv0, zp = view.camera.project(P)
        n, s = len(idx), len(self._search)
        cand = (uv0[:, None, :] + self._search[None]).reshape(-1, 2)  # (n*s, 2), search[0] = (0, 0)
        lifted, valid = self._lift(cand, view.depth, view.camera, c.max_depth)
        valid &= inside(view, c.border_px, cand) & np.repeat(zp > 0, s)
        lifted = lifted.reshape(n, s, 3)
        valid = valid.reshape(n, s)
        zr = cam_z(view, np.nan_to_num(lifted[:, 0]))
        d = zp - zr  # > 0: the surface reading is in front of the point
        exact = valid[:, 0] & (d >= -c.occlusion_tol) & (d <= c.occlusion_tol + c.inside_tol)
        dist = np.where(valid, np.linalg.norm(lifted - P[:, None], axis=2), np.inf)
        best = np.argmin(dist, axis=1)
        near = dist[np.arange(n), best] <= c.occlusion_tol
        pick = np.where(exact, 0, best)
        ok = exact | near
        slots = idx * K
        # Clear every slot of the points being (re)seeded.
        for j in range(K):
            st.active[slots + j] = False
        sel = slots[ok]
        rows = np.flatnonzero(ok)
        anchor_lift = lifted[rows, pick[rows]]
        st.uv[sel] = cand.reshape(n, s, 2)[rows, pick[rows]]
        st.offset[sel] = P[rows] - anchor_lift
        st.z[sel] = cam_z(view, anchor_lift)
        st.xyz[sel] = anchor_lift
        st.chroma[sel] = chroma_at(view.rgb, st.uv[sel], c.chroma_min_sum)
        st.active[sel] = True
        seeded = bool(sel.size)
        if K > 1:
            seeded |= self._seed_extra(view, st, idx, P, uv0, zp)
        st.rekey |= seeded

    def _seed_extra(self, view: View, st: ViewState, idx: np.ndarray, P: np.ndarray, uv0: np.ndarray,
                    zp: np.ndarray) -> bool:
        """Fill slots 1..K-1 of points ``idx`` with surface pixels within ``anchor_radius`` of them."""
        c, K = self.config, self._K
        n, r = len(idx), len(self._ring)
        cand = (uv0[:, None, :] + self._ring[None]).reshape(-1, 2)
        lifted, valid = self._lift(cand, view.depth, view.camera, c.max_depth)
        valid &= inside(view, c.border_px, cand) & np.repeat(zp > 0, r)
        lifted = lifted.reshape(n, r, 3)
        valid = valid.reshape(n, r)
        dist = np.where(valid, np.linalg.norm(lifted - P[:, None], axis=2), np.inf)
        any_seeded = False
        for row in range(n):
            good = np.flatnonzero(dist[row] <= c.anchor_radius)
            if good.size == 0:
                continue
            take = good[np.unique(np.linspace(0, good.size - 1, min(K - 1, good.size)).round().astype(int))]
            base = idx[row] * K + 1
            sl = np.arange(base, base + len(take))
            st.uv[sl] = cand.reshape(n, r, 2)[row, take]
            st.offset[sl] = P[row] - lifted[row, take]
            st.z[sl] = cam_z(view, lifted[row, take])
            st.xyz[sl] = lifted[row, take]
            st.chroma[sl] = chroma_at(view.rgb, st.uv[sl], c.chroma_min_sum)
            st.active[sl] = True
            any_seeded = True
        return any_seeded

    def _update_points(self, fused: np.ndarray, ok: np.ndarray) -> None:
        c = self.config
        for eid, sl in self._slices.items():
            o = ok[sl]
            kind = self._elements[eid].kind
            if c.rigid and kind in _RIGID_KINDS and o.sum() >= c.rigid_min_points:
                R, t, rms = kabsch(self.ref[sl][o], fused[sl][o])
                if rms <= c.rigid_max_residual:
                    self.P[sl] = self.ref[sl] @ R.T + t
                    self.stale[sl] = False
                    continue
            self.P[sl][o] = fused[sl][o]
            self.stale[sl] = ~o

    def _maybe_reacquire(self, obs: Observation) -> None:
        c = self.config
        for eid, sl in self._slices.items():
            if not self.stale[sl].any():
                self._stale_frames[eid] = 0
                continue
            self._stale_frames[eid] += 1
            if self._reacquire is None or self._stale_frames[eid] <= c.reacquire_after:
                continue
            self._stale_frames[eid] = 0  # retry only after another period
            old = self._elements[eid]
            cur = Element(old.id, old.name, old.kind, self.P[sl].copy(), old.owner, old.color)
            new = self._reacquire(obs, cur)
            if new is None:
                continue
            if new.id != eid:
                raise PerceptionError(f"reacquire hook returned element {new.id} for element {eid}")
            self._replace(obs, new)  # this frame's position is a paint: its support is the paint's unhidden points
            self._support[eid] = new.support.points * (1.0 - new.support.robot_hidden) if new.support else 0.0

    def _replace(self, obs: Observation, new: Element) -> None:
        """Swap in a re-detected element (any point count) and seed it in every view."""
        sl = self._slices[new.id]
        if len(new.points) != sl.stop - sl.start:  # re-layout, keeping every other point's state
            old_slices, old_views = self._slices, self._views
            old_P, old_stale = self.P, self.stale
            self._elements[new.id] = new
            tracked = [self._elements[i] for i in old_slices]
            frames = dict(self._stale_frames)
            self._layout(tracked)
            self._stale_frames = frames
            self._views = {}
            K = self._K
            for name, ost in old_views.items():
                st = self._views[name] = ViewState(len(self.P) * K)
                st.gray, st.key, st.key_uv[:] = ost.gray, ost.key, 0.0
                for eid, o in old_slices.items():
                    if eid != new.id:
                        nsl = slots(self._slices[eid], K)
                        osl = slots(o, K)
                        st.uv[nsl], st.active[nsl], st.key_uv[nsl] = ost.uv[osl], ost.active[osl], ost.key_uv[osl]
                        st.offset[nsl], st.z[nsl], st.xyz[nsl] = ost.offset[osl], ost.z[osl], ost.xyz[osl]
                        st.chroma[nsl] = ost.chroma[osl]
            for eid, osl in old_slices.items():
                if eid != new.id:
                    self.P[self._slices[eid]] = old_P[osl]
                    self.stale[self._slices[eid]] = old_stale[osl]
            sl = self._slices[new.id]
        self._elements[new.id] = new
        self.P[sl] = new.points
        self.ref[sl] = new.points
        self.stale[sl] = False
        self._stale_frames[new.id] = 0
        want = np.zeros(len(self.P), dtype=bool)
        want[sl] = True
        for name, view in obs.views.items():
            st = self._views[name]
            st.active[slots(sl, self._K)] = False
            self._seed(view, st, want)
            if st.rekey and st.gray is not None:
                st.make_key()  # the new anchors' templates come from this frame

    def _result(self, obs: Observation, visible_tracked: dict[int, int]) -> TrackResult:
        points: dict[int, np.ndarray] = {}
        stale: dict[int, np.ndarray] = {}
        visible: dict[int, int] = {}
        support = {eid: math.inf if eid in self._anchors else self._support.get(eid, 0.0) for eid in self._order}
        for eid in self._order:
            if eid in self._anchors:  # forward kinematics
                points[eid], stale[eid], visible[eid] = self._anchors[eid].observe(obs)
            else:
                sl = self._slices[eid]
                points[eid] = self.P[sl].copy()
                stale[eid] = self.stale[sl].copy()
                visible[eid] = visible_tracked.get(eid, 0)
        return TrackResult(obs.t, points, stale, visible, support)
