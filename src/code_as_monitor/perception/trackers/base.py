"""Tracker interface, the tracker stage registry and its factory.

A tracker follows the painted elements from frame to frame (streaming)::

    tracker = make_tracker(TrackerConfig.from_name("lk"))
    tracker.set_reacquire(fn)            # optional: fn(obs, element) -> Element | None
    tracker.set_segmenter(segmenter)     # optional: the painter's segmenter (depth: small bodies)
    tracker.reset(obs0, elements)        # elements: list[Element], points (k, 3) world metres
    res = tracker.step(obs1)             # res.points[id] (k, 3) world, res.stale[id] (k,) bool

A point the tracker has lost is *stale*: it keeps its last good position and is flagged, never replaced by a guess.
Elements owned by the robot's end-effector (owner object ``"robot"`` by default) follow forward kinematics
(``obs.robot.ee_points[part]``, else ``obs.robot.ee_pose``) in every backend: they are never tracked in images.
The backend configs are registered here; implementations (``lk``, ``depth``, ``sim``) load in :func:`make_tracker`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.observation import Observation
from code_as_monitor.core.registry import Choice, build_lazily, check_positive

ReacquireFn = Callable[[Observation, Element], "Element | None"]


@dataclass
class TrackerConfig(Choice):
    """Base of the tracker stage configs (``TrackerConfig.from_name("lk", window=25)``).

    Attributes:
        kinematic_owners: owner object names whose elements follow the robot's forward kinematics.
    """

    kinematic_owners: tuple[str, ...] = ("robot",)


@TrackerConfig.register("sim")
@dataclass
class SimTrackerConfig(TrackerConfig):
    """Oracle tracker: elements move rigidly with their owner's ground-truth pose (``Observation.object_poses``)."""


@TrackerConfig.register("lk")
@dataclass
class LKTrackerConfig(TrackerConfig):
    """Pyramidal Lucas-Kanade per view, lifted with depth and fused across views.

    Attributes:
        window: LK window side, pixels (odd; 21-31 suits textureless blocks).
        levels: pyramid levels above the base image (``maxLevel``).
        iterations, epsilon: LK termination criteria.
        fb_threshold_px: forward-backward error above this (pixels) -> lost in that view.
        rekey_px: points are tracked from a per-view key frame (not frame to frame, so errors do not
            accumulate); the key frame is renewed when a track moves more than this (pixels) from its
            key-frame position, or a point is (re)seeded in the view. 0 = frame-to-frame tracking.
        min_eig: LK minimum eigenvalue threshold (``minEigThreshold``).
        occlusion_tol: metres; a point is visible in a view when the depth reading at its projection
            agrees with the point's depth to within this (see ``inside_tol``).
        inside_tol: metres; a point may also lie up to this much further behind the observed surface
            (points inside an object, such as a fitted line's axis).
        seed_search_px: when the projection itself does not see the point (element corners on an
            object's boundary), the nearest pixel within this radius whose lifted point is within
            ``occlusion_tol`` of it is tracked instead (0 disables the search).
        max_depth_jump: metres; a tracked pixel whose depth reading jumps more than this between
            frames slid onto another surface -> lost in that view.
        border_px: a projection or track closer than this to the image border is out of the view.
        max_depth: metres; depth readings beyond this are invalid (passed to the lifting).
        fusion: "mean" or "median" of the per-view 3-D estimates.
        rigid: for line/surface elements, fit a rigid transform (Kabsch) from the element's reference
            shape to its validly tracked points and apply it to all its points.
        rigid_min_points: points needed for the rigid fit (>= 3).
        rigid_max_residual: metres; the fit is rejected (per-point estimates kept) above this RMS.
        reacquire_after: frames an element may have a stale point before the reacquire hook runs
            (and the wait before retrying after the hook found nothing).
        anchors: tracked pixels per element point and view. The first is the point's own pixel (or the
            nearest one seeing it); the others are surface pixels within ``anchor_radius`` of the point
            in 3-D, each with its own offset. The point's estimate is the median over its anchors, so
            it survives when its own pixel is covered (a suction cup over a block's top face). 1 = the
            point's own pixel only.
        anchor_radius: metres; how far from the point (3-D) extra anchors may lie on the surface.
        anchor_search_px: radius in pixels of the window searched for extra anchors.
        reseed_below: re-seed a point in a view when fewer than this fraction of its anchors are
            still tracked there.
        ee_prior_radius: metres; anchors within this distance of the end-effector tip are tracked from
            two initial guesses, where they were and where the tip's motion since the last frame would
            have carried them, and the one that passes the forward-backward check with the smaller error
            is kept: a held object moves with the gripper, a dropped one does not. 0 disables it.
        max_chroma_change: an anchor whose colour's chromaticity ((R, G) / (R + G + B) of its 3x3 pixels) has moved
            further than this from its value when it was seeded is lost in that view: it slid onto another surface
            whose grey level is alike (the block below in a tower, an object passing in front). Chromaticity does
            not change with shading. 0 disables the test.
        chroma_min_sum: pixels darker than this (R + G + B, 0-765) have no reliable colour: the test is skipped.
        max_view_disagreement: metres; a point whose estimates from two views lie further apart than this is not
            observed this frame (stale): at least one view's anchors slid, and which is not known. 0 disables it.
    """

    window: int = 21
    levels: int = 3
    iterations: int = 30
    epsilon: float = 0.01
    fb_threshold_px: float = 1.0
    rekey_px: float = 20.0
    min_eig: float = 1e-4
    occlusion_tol: float = 0.015
    inside_tol: float = 0.02
    seed_search_px: int = 6
    max_depth_jump: float = 0.01
    border_px: int = 4
    max_depth: float = 5.0
    fusion: str = "mean"
    rigid: bool = True
    rigid_min_points: int = 3
    rigid_max_residual: float = 0.01
    reacquire_after: int = 2
    anchors: int = 6
    anchor_radius: float = 0.025
    anchor_search_px: int = 14
    reseed_below: float = 0.5
    ee_prior_radius: float = 0.08
    max_chroma_change: float = 0.2
    chroma_min_sum: float = 60.0
    max_view_disagreement: float = 0.01

    def __post_init__(self) -> None:
        if self.anchors < 1:
            raise ConfigError(f"lk.anchors must be >= 1, got {self.anchors!r}")
        if not 0.0 <= self.reseed_below <= 1.0:
            raise ConfigError(f"lk.reseed_below must be in [0, 1], got {self.reseed_below!r}")
        if self.window < 5 or self.window % 2 == 0:
            raise ConfigError(f"lk.window must be an odd number >= 5, got {self.window!r}")
        if self.fusion not in ("mean", "median"):
            raise ConfigError(f"lk.fusion must be 'mean' or 'median', got {self.fusion!r}")
        if self.rigid_min_points < 3:
            raise ConfigError(f"lk.rigid_min_points must be >= 3, got {self.rigid_min_points!r}")
        check_positive("lk", "levels", self.levels, allow_zero=True)
        for f in ("iterations", "epsilon", "fb_threshold_px", "occlusion_tol", "max_depth_jump",
                  "max_depth", "rigid_max_residual", "reacquire_after"):
            check_positive("lk", f, getattr(self, f))
        for f in ("border_px", "inside_tol", "seed_search_px", "ee_prior_radius", "max_chroma_change",
                  "chroma_min_sum", "max_view_disagreement"):
            check_positive("lk", f, getattr(self, f), allow_zero=True)
        check_positive("lk", "min_eig", self.min_eig, allow_zero=True)
        check_positive("lk", "rekey_px", self.rekey_px, allow_zero=True)


@TrackerConfig.register("depth")
@dataclass
class DepthTrackerConfig(TrackerConfig):
    """Each element's object or part followed in 3-D by registering its painted cloud to the current depth
    images of all views with small_gicp (see :mod:`code_as_monitor.perception.trackers.depth`).

    Attributes:
        registration: small_gicp registration type: "PLANE_ICP" (point-to-plane), "GICP" or "ICP".
        max_correspondence: metres; correspondence distances of the successive ICP rounds, coarse to fine.
        max_iterations: ICP iterations per round.
        min_information: a direction whose translation information (from the registration's Hessian) is
            below this fraction of the strongest direction's is not observed (only vertical faces seen:
            height unknown); the translation keeps the guess's value along it (0 disables).
        voxel: metres; the model and the cropped scene are voxel-downsampled to this ...
        max_model_points: ... or to a coarser grid that leaves a body's model at most this many points.
        margin_px: the scene is cropped to the predicted poses' image bounding box grown by this.
        box_margin: metres; ... and to their world bounding box grown by this.
        depth_tol: metres; a model point is seen when the depth reading at its pixel is within this of its
            depth, contradicted when the reading lies further than this behind it.
        support_chroma: a model point seen at its depth whose pixel's chromaticity ((R, G) / (R + G + B)) is
            further than this from the point's own when painted is *recoloured*: another object's surface may be
            there, and the search ranks poses by the points seen in their own colour
            (:func:`.depth_body.support`, :func:`.depth_search.score`; 0 disables the colour test).
        chroma_min_sum: pixels darker than this (R + G + B, 0-765) have no reliable colour: the test is skipped.
        min_seen: a pose needs at least this many model points seen ...
        min_seen_frac: ... and at least this fraction of the points seen when the body was painted ...
        max_contradiction: ... and at most this fraction of its informative points contradicted;
            otherwise the body is lost this frame and its elements are stale.
        max_rotation: degrees; a registration that turns its guess further than this is not taken (a block
            seen from two faces has symmetric fits a quarter turn away; nothing turns that fast here).
        fall_correspondence: metres; the first ICP round's correspondence distance from a falling guess.
        fall_seen_frac: a falling guess's result must see at least this fraction of the points the body's
            last good pose saw (a fall is searched from far: a half-way fit must not pass).
        related_parts: a part is also tried where the nearest this many other parts of its object that
            moved this frame took it (a drawer moves with its handle); 0 disables.
        max_overlap: when this fraction of one body's model points lies on another object's body (within
            ``depth_tol``), the two claim the same surface: the one painted longer ago (or, painted
            together, the one that moved further) is lost.
        unmoved_seen, unmoved_residual: a body neither held nor moved by its object keeps its pose without
            registration when, there, the new frame sees at least ``unmoved_seen`` of the points the last
            frame saw, hardly more contradicted ones, and a mean depth residual at most ``unmoved_residual``
            metres above the last (a body at rest costs one projection).
        plane_band: metres; points this close to the dominant (support) plane fitted at reset are left
            out of models and scenes (0 disables the plane).
        tool_radius, tool_margin: metres; scene points further than ``tool_margin`` up the tool axis from
            the end-effector tip and within ``tool_radius`` of the axis are the end-effector, left out (the
            radius grows to hold the robot state's named end-effector points, e.g. a gripper's jaws).
        held_distance: metres; a body whose model comes this close to the tip while the gripper or
            suction is on is also tried where the end-effector's motion since the last frame moved it.
        moving: metres per frame; a body that moved more than this last frame is also tried at a constant
            velocity and on a ballistic (falling) path.
        gravity: metres / s^2 along world -z, for the ballistic guess.
        reacquire_after: frames a body may be lost before the reacquire hook runs (and the wait before
            retrying after the hook found nothing).
        max_depth: metres; depth readings beyond this are invalid.
        min_points: fewest model points (after downsampling) a body needs to be tracked.
        detect_points, detect_extent: a body whose model has fewer than ``detect_points`` points, or a largest
            principal extent of at most ``detect_extent`` metres, is too small to register (too few points to
            pin a pose; the first ICP round reaches across it to a touching neighbour): with a segmenter it is
            tracked by detection (:mod:`.depth_detect`); both 0: every body is registered.
        detect_min_pixels: a detection (a mask in one view) needs at least this many valid depth pixels.
        detect_gate: a tracked small body takes a detection at most this many of its extents from its
            predicted position (identical solid neighbours are about one extent apart).
        detect_reacquire_gate: a lost small body's gate grows by two extents per lost frame up to this many.
        detect_chroma: a small body takes no detection whose chromaticity ((R, G, B) / (R + G + B) of the mask)
            is further than this from its own when first detected (0 disables the test).
        detect_chain: a small body the tool's tip passed within half its extent plus this many extents of, or
            within about this many extents ahead of such a body (a pile pushes on), is also looked for
            where the tool's step would have pushed it (0: no such guess).
    """

    registration: str = "PLANE_ICP"
    max_correspondence: tuple[float, ...] = (0.02, 0.006)
    max_iterations: int = 12
    min_information: float = 0.05
    voxel: float = 0.003
    max_model_points: int = 500
    margin_px: int = 8
    box_margin: float = 0.025
    depth_tol: float = 0.005
    support_chroma: float = 0.15
    chroma_min_sum: float = 60.0
    min_seen: int = 15
    min_seen_frac: float = 0.1
    max_contradiction: float = 0.15
    max_overlap: float = 0.3
    related_parts: int = 2
    max_rotation: float = 45.0
    fall_correspondence: float = 0.04
    fall_seen_frac: float = 0.5
    unmoved_seen: float = 0.97
    unmoved_residual: float = 0.0005
    plane_band: float = 0.004
    tool_radius: float = 0.02
    tool_margin: float = 0.004
    held_distance: float = 0.02
    moving: float = 0.003
    gravity: float = 9.81
    reacquire_after: int = 2
    max_depth: float = 5.0
    min_points: int = 8
    detect_points: int = 30
    detect_extent: float = 0.04
    detect_min_pixels: int = 3
    detect_gate: float = 1.0
    detect_reacquire_gate: float = 20.0
    detect_chroma: float = 0.1
    detect_chain: float = 0.5

    def __post_init__(self) -> None:
        if self.registration not in ("PLANE_ICP", "GICP", "ICP"):
            raise ConfigError(f"depth.registration must be PLANE_ICP, GICP or ICP, got {self.registration!r}")
        self.max_correspondence = tuple(float(x) for x in self.max_correspondence)
        if not self.max_correspondence or min(self.max_correspondence) <= 0:
            raise ConfigError(f"depth.max_correspondence must be positive distances, got {self.max_correspondence!r}")
        if not 0.0 <= self.min_seen_frac <= 1.0:
            raise ConfigError(f"depth.min_seen_frac must be in [0, 1], got {self.min_seen_frac!r}")
        if not 0.0 <= self.fall_seen_frac <= 1.0:
            raise ConfigError(f"depth.fall_seen_frac must be in [0, 1], got {self.fall_seen_frac!r}")
        check_positive("depth", "fall_correspondence", self.fall_correspondence)
        if not 0.0 < self.unmoved_seen <= 1.0:
            raise ConfigError(f"depth.unmoved_seen must be in (0, 1], got {self.unmoved_seen!r}")
        check_positive("depth", "unmoved_residual", self.unmoved_residual, allow_zero=True)
        if not 0.0 < self.max_overlap <= 1.0:
            raise ConfigError(f"depth.max_overlap must be in (0, 1], got {self.max_overlap!r}")
        if not 0.0 <= self.max_contradiction <= 1.0:
            raise ConfigError(f"depth.max_contradiction must be in [0, 1], got {self.max_contradiction!r}")
        for f in ("max_iterations", "voxel", "max_model_points", "max_rotation", "depth_tol", "min_seen",
                  "max_depth", "min_points", "reacquire_after", "detect_min_pixels", "detect_gate"):
            check_positive("depth", f, getattr(self, f))
        if self.detect_reacquire_gate < self.detect_gate:
            raise ConfigError(f"depth.detect_reacquire_gate ({self.detect_reacquire_gate!r}) must be >= "
                              f"depth.detect_gate ({self.detect_gate!r})")
        for f in ("related_parts", "min_information", "margin_px", "box_margin", "plane_band", "tool_radius",
                  "tool_margin", "held_distance", "moving", "gravity", "detect_points", "detect_extent",
                  "detect_chain", "detect_chroma", "support_chroma", "chroma_min_sum"):
            check_positive("depth", f, getattr(self, f), allow_zero=True)


@dataclass
class TrackResult:
    """Element positions at one frame.

    Attributes:
        t: observation time, seconds.
        points: element id -> (k, 3) world metres (a stale point holds its last good position).
        stale: element id -> (k,) bool, True where the point was not observed this frame.
        visible_views: element id -> number of views in which at least one of its points was
            observed this frame (kinematic elements count the views they project into).
        support: element id -> observations this position rests on (``lk``: anchor estimates; ``depth``: model points
            its pose saw; ``inf``: exact, the oracle). Not reported: none known (the carry-over trusts no such move).
    """

    t: float
    points: dict[int, np.ndarray]
    stale: dict[int, np.ndarray]
    visible_views: dict[int, int] = field(default_factory=dict)
    support: dict[int, float] = field(default_factory=dict)

    def any_stale(self) -> list[int]:
        """Ids of elements with at least one stale point."""
        return [i for i, s in self.stale.items() if s.any()]


class Tracker(ABC):
    """A streaming element tracker."""

    def __init__(self) -> None:
        self._reacquire: ReacquireFn | None = None
        self._segmenter: object | None = None

    def set_reacquire(self, fn: ReacquireFn | None) -> None:
        """Hook that re-detects a lost element: ``fn(obs, element) -> Element | None`` (same id)."""
        self._reacquire = fn

    def set_segmenter(self, segmenter: object | None) -> None:
        """The segmenter the painter uses (``segment_many(view, specs) -> [SegmentResult]``), for a tracker
        that detects objects every frame (the ``depth`` tracker's small bodies); the others ignore it."""
        self._segmenter = segmenter

    @abstractmethod
    def reset(self, obs: Observation, elements: list[Element]) -> None:
        """Start tracking ``elements`` (points (k, 3) world metres) from ``obs``."""

    @abstractmethod
    def step(self, obs: Observation) -> TrackResult:
        """Advance to ``obs``; return every element's current points, stale flags and view counts."""


_IMPLEMENTATIONS: dict[str, str] = {
    "sim": "code_as_monitor.perception.trackers.sim:SimTracker",
    "lk": "code_as_monitor.perception.trackers.lk:LKTracker",
    "depth": "code_as_monitor.perception.trackers.depth:DepthTracker",
}


def make_tracker(config: TrackerConfig) -> Tracker:
    """Build the tracker for ``config``, importing its implementation module only now."""
    return build_lazily(_IMPLEMENTATIONS, config, "tracker")
