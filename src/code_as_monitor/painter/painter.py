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
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.constraints import Subgoal
from code_as_monitor.core.elements import Element, ElementSpec
from code_as_monitor.core.errors import CamError, PerceptionError
from code_as_monitor.core.observation import Observation
from code_as_monitor.painter.draw import draw_elements

log = logging.getLogger(__name__)

ROBOT = "robot"


@dataclass
class PaintResult:
    """What the painter produced for one subgoal.

    Attributes:
        elements: the elements, ids 0..n-1 (missing ones are absent).
        specs: element id -> the spec it abstracts (including missing ones).
        images: view name -> annotated RGB (H, W, 3) uint8: the visual prompt.
        missing: specs that no view could see (the caller decides: re-plan or fail).
        seconds: wall time spent.
    """

    elements: list[Element]
    specs: dict[int, ElementSpec]
    images: dict[str, np.ndarray]
    missing: list[ElementSpec] = field(default_factory=list)
    seconds: float = 0.0

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
    """

    def __init__(self, segmenter: object, min_pixels: int = 12) -> None:
        self.segmenter = segmenter
        self.min_pixels = min_pixels

    def build_element(
        self, obs: Observation, element_id: int, spec: ElementSpec, constraint_text: str = ""
    ) -> Element | None:
        """Build one element from all views, or None when no view sees it."""
        from code_as_monitor.geometry import build_element, ee_element

        if spec.obj == ROBOT:
            if obs.robot is None:
                return None
            part = spec.part or "tip"
            point = obs.robot.ee_points.get(part)
            if point is None:
                point = obs.robot.ee_pose[:3, 3]
            return ee_element(element_id, spec.name, np.asarray(point), owner=(spec.obj, part))
        per_view = []
        results = [(view, self.segmenter.segment(view, spec, constraint_text))  # type: ignore[attr-defined]
                   for view in obs.views.values()]
        whole = [(r.instance_mask, v.depth, v.camera) for v, r in results if r.instance_mask.sum() >= self.min_pixels]
        # A part seen well enough in some view is built from part masks only: falling back to the whole
        # object in a view that sees the part too small would pull the element off the part.
        part_seen = bool(spec.part) and any(r.part_mask.sum() >= self.min_pixels for _, r in results)
        for view, res in results:
            if part_seen:
                mask = res.part_mask
            else:
                mask = res.part_mask if res.part_mask.sum() >= self.min_pixels else res.instance_mask
            if spec.part and res.part_mask.sum() < self.min_pixels and res.instance_mask.sum() >= self.min_pixels:
                log.debug("part %s/%s not segmented in %s; using the whole object", spec.obj, spec.part,
                          view.camera.name)
            if mask.sum() >= self.min_pixels:
                per_view.append((mask, view.depth, view.camera))
        if not per_view:
            return None
        try:
            el = build_element(element_id, spec, per_view)
            if not spec.part:
                el.object_cloud = el.cloud
            elif whole:
                from code_as_monitor.geometry import mask_cloud

                el.object_cloud = mask_cloud(whole)
            return el
        except CamError as exc:
            log.info("element %d (%s) could not be built: %s", element_id, spec.name, exc)
            return None

    def paint(self, obs: Observation, subgoal: Subgoal) -> PaintResult:
        """Build every element of ``subgoal`` from ``obs`` and draw the visual prompt on every view."""
        t0 = time.perf_counter()
        specs = assign_element_ids(subgoal)
        text_of: dict[int, str] = {}
        for c in subgoal.constraints:
            for i in c.element_ids:
                text_of.setdefault(i, c.text)
        elements: list[Element] = []
        missing: list[ElementSpec] = []
        for eid, spec in specs.items():
            el = self.build_element(obs, eid, spec, text_of.get(eid, ""))
            if el is None:
                missing.append(spec)
            else:
                elements.append(el)
        images = self.draw(obs, elements)
        return PaintResult(elements, specs, images, missing, time.perf_counter() - t0)

    @staticmethod
    def draw(
        obs: Observation, elements: list[Element], stale: dict[int, np.ndarray] | None = None
    ) -> dict[str, np.ndarray]:
        """Annotated copies of every view's RGB."""
        return {name: draw_elements(v.rgb, v.camera, elements, stale) for name, v in obs.views.items()}


def require_all(result: PaintResult) -> None:
    """Raise PerceptionError naming the parts no view could see."""
    if result.missing:
        names = ", ".join(f"{s.obj}/{s.part or '*'} ({s.name})" for s in result.missing)
        raise PerceptionError(f"no view sees: {names}")
