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


class SimSegmenter(Segmenter):
    """Exact masks from ``View.seg``; score 1 when visible, 0 when not."""

    def __init__(self, config: SimSegmenterConfig | None = None) -> None:
        self.config = config or SimSegmenterConfig()

    def segment(self, view: View, spec: ElementSpec, constraint_text: str = "") -> SegmentResult:
        if view.seg is None or view.seg_labels is None:
            raise PerceptionError(
                f"view {view.camera.name!r} has no ground-truth seg image; the sim segmenter needs one "
                "(use the color or http segmenter on real images)"
            )
        labels = view.seg_labels
        obj_ids = [i for i, (o, _) in labels.items() if o == spec.obj]
        if not obj_ids:
            known = sorted({o for o, _ in labels.values()})
            raise PerceptionError(f"unknown object {spec.obj!r}; the scene has: {', '.join(known)}")
        if spec.part:
            part_ids = [i for i in obj_ids if labels[i][1] == spec.part]
            if not part_ids:
                parts = sorted({labels[i][1] for i in obj_ids if labels[i][1]})
                raise PerceptionError(
                    f"unknown part {spec.part!r} of {spec.obj!r}; its parts: {', '.join(parts) or '(none)'}"
                )
        else:
            part_ids = obj_ids
        instance = np.isin(view.seg, obj_ids)
        part = instance if part_ids is obj_ids else np.isin(view.seg, part_ids)
        score = 1.0 if part.any() else 0.0
        return SegmentResult(instance, part.copy() if part is instance else part, spec.kind, score)
