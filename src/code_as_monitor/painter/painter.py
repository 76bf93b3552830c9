"""The constraint painter: a subgoal's constraints -> numbered constraint elements -> visual prompts.

For each part a constraint involves, the segmenter gives instance and part masks on every view; the
geometry layer lifts them with depth, fuses the views and abstracts them into an element of the
requested kind. End-effector parts (object ``robot``) come straight from forward kinematics.
Elements are numbered 0..n-1 in order of first appearance across the subgoal's constraints, with
repeated (object, part, kind) triples sharing one element; ``Constraint.element_ids`` is filled in.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from code_as_monitor.core.constraints import Subgoal
from code_as_monitor.core.elements import Element, ElementKind, ElementSpec
from code_as_monitor.core.errors import CamError, ConfigError, PerceptionError
from code_as_monitor.core.observation import Observation
from code_as_monitor.geometry.occlusion import any_point_near, ball_pixel_box
from code_as_monitor.geometry.stats import percentile
from code_as_monitor.painter.carry_over import (
    CarryDecision,
    Key,
    KnownElement,
    candidate,
    carry_over,
    key_of,
    stands_in,
)
from code_as_monitor.painter.draw import draw_elements
from code_as_monitor.painter.point_elements import SplitPoint, split_into_points
from code_as_monitor.painter.sources import ORB_KEYPOINTS, PART_MASKS, check_element_source

if TYPE_CHECKING:
    from code_as_monitor.geometry.support import SupportPlane

log = logging.getLogger(__name__)

ROBOT = "robot"
HELD_RADIUS = 0.025
"""Metres: with the gripper closed, an object with a visible point this near the tool tip is held (it hides as the
robot). The fingers cover the object around the grasp point: at the subgoal starts of stow-book episode 952385804 the
held book's nearest visible point was 0.8-1.6 cm from the tip; at 1.5 cm the 1.6 cm start was not counted as held, the
upright book's spine seen end-on was not carried over, and the stow read it 85 degrees off (RESULTS, 2026-11-28)."""
HELD_SIZE = 0.3
"""Metres: a held object lies within this of the tip (95 % of its points): the table the tip touches is not held."""


@dataclass
class PaintResult:
    """What the painter produced for one subgoal.

    Attributes:
        elements: the elements, ids 0..n-1 (missing ones are absent).
        specs: element id -> the spec it abstracts (including missing ones).
        images: view name -> annotated RGB (H, W, 3) uint8: the visual prompt.
        missing: specs that no view could see (the caller decides: re-plan or fail).
        seconds: wall time spent.
        carried: the carry-over decisions (:mod:`~code_as_monitor.painter.carry_over`) for the elements the robot
            hid and that had a remembered estimate: which were carried, which kept their fresh measurement, why.
    """

    elements: list[Element]
    specs: dict[int, ElementSpec]
    images: dict[str, np.ndarray]
    missing: list[ElementSpec] = field(default_factory=list)
    seconds: float = 0.0
    carried: list[CarryDecision] = field(default_factory=list)

    def legend(self) -> list[dict]:
        """One entry per element: id, kind, name, owner (what the coder prompt lists)."""
        return [
            {"id": e.id, "kind": e.kind.value, "name": e.name, "owner": list(e.owner)} for e in self.elements
        ]


def assign_element_ids(subgoal: Subgoal) -> dict[int, ElementSpec]:
    """Number the subgoal's parts (deduplicated by object, part, kind) and fill ``element_ids``."""
    ids: dict[tuple[str, str, str], int] = {}
    specs: dict[int, ElementSpec] = {}
    for c in subgoal.constraints:
        c.element_ids = []
        for spec in c.parts:
            key = (spec.obj, spec.part, spec.kind.value)
            if key not in ids:
                ids[key] = len(ids)
                specs[ids[key]] = spec
            c.element_ids.append(ids[key])
    return specs


class Painter:
    """Builds and draws the elements of a subgoal.

    Args:
        segmenter: any object with ``segment(view, spec, constraint_text) -> SegmentResult``
            (``code_as_monitor.perception.segmenters``).
        min_pixels: a view contributes to an element only when its mask has at least this many pixels.
        element_source: ``part-masks`` (the method: constraint-aware instance and part masks, fitted) or
            ``orb-keypoints`` (the ablation "CS off": ORB keypoints on the object's image region, lifted with depth
            and clustered with k-means, :mod:`~code_as_monitor.painter.keypoint_elements`; not DINOv2).
        connect_points: form lines and surfaces (the method). False (the ablation "CP off",
            :mod:`~code_as_monitor.painter.point_elements`): every element is handed over as unconnected points,
            each a point element of its own, and the subgoal's constraints are rewritten to use them.
    """

    def __init__(self, segmenter: object, min_pixels: int = 12, element_source: str = PART_MASKS,
                 connect_points: bool = True) -> None:
        self.segmenter = segmenter
        self.min_pixels = min_pixels
        self.element_source = check_element_source(element_source)
        if not isinstance(connect_points, bool):
            raise ConfigError(f"Painter.connect_points must be true or false, got {connect_points!r}")
        self.connect_points = connect_points
        self._plane: tuple[int, SupportPlane | None] | None = None
        self._split: dict[int, SplitPoint] = {}
        self._held_now: list[str] = []  # the objects the robot held at the last build (see _held)

    def _support(self, obs: Observation) -> SupportPlane | None:
        """The scene's support plane (the table) from this observation's depth, computed once per observation."""
        from code_as_monitor.geometry.support import support_plane

        if self._plane is None or self._plane[0] != id(obs):
            self._plane = (id(obs), support_plane([(v.depth, v.camera) for v in obs.views.values()]))
        return self._plane[1]

    def build_element(
        self, obs: Observation, element_id: int, spec: ElementSpec, constraint_text: str = ""
    ) -> Element | None:
        """Build one element from all views, or None when no view sees it. With ``connect_points`` False, a point
        split from a line or surface at the last :meth:`paint` is that element's point, rebuilt."""
        split = self._split.get(element_id)
        if split is not None and not self.connect_points and spec.obj == split.parent.obj \
                and spec.part == split.parent.part:
            whole = self.build_elements(obs, {split.parent_id: split.parent}, {split.parent_id: constraint_text})
            el = whole[split.parent_id]
            if el is None or len(el.points) <= split.index:
                return None
            p = Element.point(element_id, spec.name, el.points[split.index], el.owner)
            p.cloud, p.object_cloud, p.support = el.cloud, el.object_cloud, el.support
            return p
        built = self.build_elements(obs, {element_id: spec}, {element_id: constraint_text})[element_id]
        if built is not None and not self.connect_points and built.kind is not ElementKind.POINT:
            built = Element.point(element_id, spec.name, built.points.mean(axis=0), built.owner)
        return built

    def build_elements(
        self, obs: Observation, specs: dict[int, ElementSpec], texts: dict[int, str] | None = None
    ) -> dict[int, Element | None]:
        """Build several elements in one pass over each view: every view is segmented for all of them at once
        (:meth:`Segmenter.segment_many`) and its depth made ready once
        (:class:`~code_as_monitor.geometry.backproject.LiftedView`: only the masks' pixels are lifted); then each
        element is fitted from its own points. None for an element no view sees (or whose fit fails).

        A view whose depth does not match its camera is skipped (logged); it never stops the others.
        """
        from code_as_monitor.geometry import ee_element

        texts = texts or {}
        out: dict[int, Element | None] = {}
        masked: list[tuple[int, ElementSpec]] = []
        for eid, spec in specs.items():
            if spec.obj != ROBOT:
                masked.append((eid, spec))
                continue
            if obs.robot is None:
                out[eid] = None
                continue
            part = spec.part or "tip"
            point = obs.robot.ee_points.get(part)
            if point is None:
                point = obs.robot.ee_pose[:3, 3]
            out[eid] = ee_element(eid, spec.name, np.asarray(point), owner=(spec.obj, part))
        if not masked:
            return out
        per_view = self._segment_and_lift(obs, [s for _, s in masked], [texts.get(e, "") for e, _ in masked])
        support = self._support(obs) if per_view else None
        robots = self._robot_masks(obs, per_view)
        for j, (eid, spec) in enumerate(masked):
            out[eid] = self._fit(eid, spec, [(v, lifted, res[j]) for v, lifted, res in per_view], support, robots)
        return out

    def _robot_masks(self, obs: Observation, per_view: list[tuple]) -> list[np.ndarray | None]:
        """Per usable view: the robot's pixels and those of what it holds (:meth:`_held`), or None where the segmenter
        cannot tell the robot."""
        robots = [self._robot_mask(v) for v, _, _ in per_view]
        self._held_now = []
        if any(r is not None for r in robots):
            held = self._held(obs, per_view)
            self._held_now = list(held)
            for masks in held.values():
                for i, m in enumerate(masks):
                    r = robots[i]
                    if r is not None:
                        robots[i] = r | np.asarray(m, dtype=bool)
        return robots

    def _held(self, obs: Observation, per_view: list[tuple]) -> dict[str, list[np.ndarray]]:
        """The objects the robot holds, each with its instance mask per view: with its gripper closed (or suction on),
        those with a lifted mask point within :data:`HELD_RADIUS` of its tip and nearly all within :data:`HELD_SIZE`.
        They move with the robot and hide parts as it does."""
        robot = obs.robot
        if robot is None or robot.gripper < 0.5 or not obs.objects:
            return {}
        tip, held = robot.tip, {}
        boxes = [None if getattr(v, "camera", None) is None else  # an object with no pixel there is not lifted
                 ball_pixel_box(v.camera, tip, HELD_RADIUS, v.depth.shape) for v, _, _ in per_view]
        for name in obs.objects:
            if name == ROBOT:
                continue
            try:
                masks = [self.segmenter.segment(v, ElementSpec(name, name)).instance_mask for v, _, _ in per_view]
                if all(b is not None for b in boxes) and not any_point_near(
                        masks, boxes, [lv for _, lv, _ in per_view], tip, HELD_RADIUS):
                    continue
                clouds = [lifted.points(m) for m, (_, lifted, _) in zip(masks, per_view)]
            except CamError:
                continue
            P = np.vstack([c for c in clouds if len(c)] or [np.empty((0, 3))])
            d = np.linalg.norm(P - tip, axis=1)
            if len(P) and float(d.min()) <= HELD_RADIUS and float(percentile(d, 95.0)) <= HELD_SIZE:
                held[name] = masks
        return held

    def _robot_mask(self, view: object) -> np.ndarray | None:
        """The robot's own pixels in ``view`` from the segmenter (None when it cannot tell the robot, or its mask
        does not match the view)."""
        fn = getattr(self.segmenter, "robot_mask", None)
        if fn is None:
            return None
        try:
            m = fn(view)
        except CamError as exc:
            log.info("no robot mask for view %r: %s", getattr(getattr(view, "camera", None), "name", "?"), exc)
            return None
        if m is None:
            return None
        m = np.asarray(m, dtype=bool)
        return m if m.shape == np.shape(getattr(view, "depth", None)) else None

    def _segment_and_lift(self, obs: Observation, specs: list[ElementSpec], texts: list[str]) -> list[tuple]:
        """Per usable view: (view, LiftedView, [SegmentResult per spec])."""
        from code_as_monitor.geometry.backproject import LiftedView

        out = []
        for name, view in obs.views.items():
            bad = unusable(view)
            if bad:
                log.warning("view %r skipped: %s", name, bad)
                continue
            lifted = LiftedView(view.depth, view.camera)
            many = getattr(self.segmenter, "segment_many", None)
            if many is not None:
                res = many(view, specs, texts)
            else:
                res = [self.segmenter.segment(view, s, t) for s, t in zip(specs, texts)]  # type: ignore[attr-defined]
            out.append((view, lifted, res))
        return out

    def _fit(self, eid: int, spec: ElementSpec, views: list[tuple], support: SupportPlane | None,
             robots: list[np.ndarray | None] | None = None) -> Element | None:
        """One element from its per-view (view, LiftedView, SegmentResult) and the robot's mask per view (or None)."""
        if self.element_source == ORB_KEYPOINTS:
            from code_as_monitor.painter.keypoint_elements import keypoint_element

            return keypoint_element(eid, spec, views, self.min_pixels)
        from code_as_monitor.painter.mask_elements import mask_element

        return mask_element(eid, spec, views, support, robots, self.min_pixels)

    def paint(self, obs: Observation, subgoal: Subgoal,
              known: Mapping[Key, KnownElement] | None = None) -> PaintResult:
        """Build every element of ``subgoal`` from ``obs`` (one pass over each view) and draw the visual prompt.

        ``known``: remembered estimates by ``(object, part, kind)`` (where the agent's tracker last had them); an
        element the robot hides is taken from one when it rests on more evidence and nothing contradicts it
        (:mod:`~code_as_monitor.painter.carry_over`). None or empty: every element is this observation's own.
        """
        t0 = time.perf_counter()
        specs = assign_element_ids(subgoal)
        text_of: dict[int, str] = {}
        for c in subgoal.constraints:
            for i in c.element_ids:
                text_of.setdefault(i, c.text)
        built = self.build_elements(obs, specs, text_of)
        decisions: list[CarryDecision] = []
        if known:
            # the robot hides the fresh element, or the part belongs to an object the robot holds (turned with it,
            # the object may hide its own part: decided on where the part was remembered, carry_over condition 1)
            cands = {i: s for i, s in specs.items() if s.obj != ROBOT and key_of(s) in known
                     and (candidate(built[i]) or s.obj in self._held_now)}
            if cands:
                figures = self._contradiction(obs, cands, built, known)
                built, decisions = carry_over(built, specs, known, figures)
        elements = [el for el in built.values() if el is not None]
        missing = [specs[i] for i, el in built.items() if el is None]
        elements.sort(key=lambda e: e.id)
        self._split = {}
        if not self.connect_points:
            elements, specs, self._split = split_into_points(elements, specs, subgoal)
        images = self.draw(obs, elements)
        return PaintResult(elements, specs, images, missing, time.perf_counter() - t0, decisions)

    def _contradiction(self, obs: Observation, cands: dict[int, ElementSpec], built: dict[int, Element | None],
                       known: Mapping[Key, KnownElement]) -> dict[int, tuple[float, float, float]]:
        """Per candidate id: (seen-through fraction, visible-outside fraction, robot-hidden fraction of the remembered
        cloud) of its remembered estimate against ``obs`` (:mod:`~code_as_monitor.geometry.occlusion`)."""
        from code_as_monitor.geometry.occlusion import OccluderView, contradiction, robot_hidden_points

        ids = list(cands)
        per_view = self._segment_and_lift(obs, [cands[i] for i in ids], [""] * len(ids))
        robots = self._robot_masks(obs, per_view)
        out = {}
        for j, eid in enumerate(ids):
            k = known[key_of(cands[eid])]
            views = [OccluderView(v.depth, v.camera, r, np.asarray(res[j].instance_mask, dtype=bool))
                     for (v, _, res), r in zip(per_view, robots)]
            cloud = k.cloud if k.cloud is not None and len(k.cloud) else k.points
            fresh = built.get(eid)
            visible = (fresh.cloud if fresh is not None and fresh.cloud is not None and not stands_in(fresh)
                       else np.empty((0, 3)))  # a whole object standing in shows none of the part's points
            seen, outside = contradiction(cloud, k.points.mean(axis=0), visible, views)
            part = [OccluderView(v.depth, v.camera, r, np.asarray(res[j].part_mask if cands[eid].part
                                                                 else res[j].instance_mask, dtype=bool))
                    for (v, _, res), r in zip(per_view, robots)]  # the part seen now does not hide itself
            out[eid] = (seen, outside, robot_hidden_points(cloud, part))
        return out

    @staticmethod
    def draw(
        obs: Observation, elements: list[Element], stale: dict[int, np.ndarray] | None = None
    ) -> dict[str, np.ndarray]:
        """Annotated copies of every view's RGB (a plain copy for a view whose camera cannot project)."""
        return {name: v.rgb.copy() if unusable(v) else draw_elements(v.rgb, v.camera, elements, stale)
                for name, v in obs.views.items()}


def unusable(view: object) -> str:
    """Why a view cannot be lifted or drawn (its camera's intrinsics or pose are invalid, or its depth does not
    match the camera), naming the bad value; "" when it can."""
    from code_as_monitor.core.camera import validate_intrinsics, validate_rigid
    from code_as_monitor.geometry.backproject import check_depth

    cam = getattr(view, "camera", None)
    try:
        if cam is None:
            return "the view has no camera"
        validate_intrinsics(getattr(cam, "K", None))
        validate_rigid(getattr(cam, "T_world_cam", None), f"camera {getattr(cam, 'name', '?')!r} T_world_cam")
        check_depth(getattr(view, "depth", None), cam)
    except CamError as exc:
        return str(exc)
    except (TypeError, ValueError) as exc:  # a value numpy cannot even read as an array
        return f"camera {getattr(cam, 'name', '?')!r}: {exc}"
    return ""


def require_all(result: PaintResult) -> None:
    """Raise PerceptionError naming the parts no view could see."""
    if result.missing:
        names = ", ".join(f"{s.obj}/{s.part or '*'} ({s.name})" for s in result.missing)
        raise PerceptionError(f"no view sees: {names}")
