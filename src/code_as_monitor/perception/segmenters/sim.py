"""Ground-truth segmentation from the id image a simulator (or a labelled log) puts in the view.

``View.seg`` is an (H, W) int32 id image and ``View.seg_labels[id] = (object, part)``; a whole-object
id has part ``""``. The object's instance mask is the union of all its ids; a part mask is the union
of the ids labelled with that part. This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.core.errors import PerceptionError
from code_as_monitor.core.observation import View
from code_as_monitor.perception.segmenters.base import Segmenter, SegmentResult, SimSegmenterConfig

ROBOT = "robot"
"""The object name the id image's labels give the robot's links (``("robot", link name)``)."""


class SimSegmenter(Segmenter):
    """Exact masks from ``View.seg``; score 1 when visible, 0 when not."""

    def __init__(self, config: SimSegmenterConfig | None = None) -> None:
        self.config = config or SimSegmenterConfig()

    def segment(self, view: View, spec: ElementSpec, constraint_text: str = "") -> SegmentResult:
        return self.segment_many(view, [spec])[0]

    def segment_many(
        self, view: View, specs: list[ElementSpec], constraint_texts: list[str] | None = None
    ) -> list[SegmentResult]:
        """All specs from the id image: a mask is the union of ``seg == id`` over the few ids of its object or
        part (a comparison per id is linear in the pixels; numbering the image's ids with ``np.unique``
        sorted every pixel, which was the most expensive step of a replay); each union is computed once per
        call (the parts of one object share its instance mask)."""
        if view.seg is None or view.seg_labels is None:
            raise PerceptionError(
                f"view {view.camera.name!r} has no ground-truth seg image; the sim segmenter needs one "
                "(use the color or http segmenter on real images)"
            )
        out = []
        made: dict[tuple[int, ...], np.ndarray] = {}  # ids -> their union, once per call (a rope's beads share it)
        given: set[tuple[int, ...]] = set()  # unions already handed to a result

        def union(ids: list[int]) -> np.ndarray:
            key = tuple(ids)
            if key not in made:
                made[key] = _union_mask(view.seg, ids)
            if key not in given:  # its first result takes the union itself
                given.add(key)
                return made[key]
            return made[key].copy()  # every result owns its masks

        for spec in specs:
            obj_ids, part_ids = self._ids(view.seg_labels, spec)
            inst = union(obj_ids)
            part = inst.copy() if part_ids is obj_ids else union(part_ids)
            out.append(SegmentResult(inst, part, spec.kind, 1.0 if part.any() else 0.0))
        return out

    def robot_mask(self, view: View) -> np.ndarray | None:
        """(H, W) bool: the pixels labelled ``("robot", link)`` in the id image; None without an id image or when
        no label is the robot's."""
        if view.seg is None or view.seg_labels is None:
            return None
        ids = [i for i, (o, _) in view.seg_labels.items() if o == ROBOT]
        return _union_mask(view.seg, ids) if ids else None

    @staticmethod
    def _ids(labels: dict[int, tuple[str, str]], spec: ElementSpec) -> tuple[list[int], list[int]]:
        """(the object's seg ids, the part's seg ids) for ``spec``; PerceptionError naming an unknown name."""
        obj_ids = [i for i, (o, _) in labels.items() if o == spec.obj]
        if not obj_ids:
            known = sorted({o for o, _ in labels.values()})
            raise PerceptionError(f"unknown object {spec.obj!r}; the scene has: {', '.join(known)}")
        if not spec.part:
            return obj_ids, obj_ids
        part_ids = [i for i in obj_ids if labels[i][1] == spec.part]
        if not part_ids:
            parts = sorted({labels[i][1] for i in obj_ids if labels[i][1]})
            raise PerceptionError(
                f"unknown part {spec.part!r} of {spec.obj!r}; its parts: {', '.join(parts) or '(none)'}"
            )
        return obj_ids, part_ids


def _union_mask(seg: np.ndarray, ids: list[int]) -> np.ndarray:
    """(H, W) bool: pixels of ``seg`` whose id is one of ``ids``."""
    if len(ids) > 16:
        return np.isin(seg, ids)
    mask = np.zeros(seg.shape, dtype=bool)
    for i in ids:
        mask |= seg == i
    return mask
