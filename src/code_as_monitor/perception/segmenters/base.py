"""Segmenter interface, the segmenter stage registry and its factory.

A segmenter turns one camera view plus an :class:`~code_as_monitor.core.ElementSpec` (object, part,
kind) into an instance mask and a part mask. The painter back-projects those masks with depth and
fits constraint elements on them.

Contract (every backend):
- an object that is known but not visible in the view gives *empty* masks and ``score == 0``;
- an object (or part) name the backend cannot know raises :class:`PerceptionError` naming it;
- ``part == ""`` means the whole object: ``part_mask`` equals ``instance_mask``.

The backend configs are registered here (they are plain dataclasses); the implementations live in
their own modules (``sim``, ``color``, ``http``) and are imported only by :func:`make_segmenter`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.observation import View
from code_as_monitor.core.registry import Choice, build_lazily, check_positive


@dataclass
class SegmenterConfig(Choice):
    """Base of the segmenter stage configs (``SegmenterConfig.from_name("color", ...)``)."""


@dataclass
class SegmentResult:
    """Masks for one element spec in one view.

    Attributes:
        instance_mask: (H, W) bool, the whole object.
        part_mask: (H, W) bool, the requested part (equals ``instance_mask`` for part ``""``).
        kind: the element kind the masks should be abstracted as (the spec's kind unless the backend
            predicts one).
        score: confidence in [0, 1]; 0 when nothing was found.
    """

    instance_mask: np.ndarray
    part_mask: np.ndarray
    kind: ElementKind
    score: float

    @property
    def empty(self) -> bool:
        """True when the part mask has no pixel (the object or part is not visible)."""
        return not bool(self.part_mask.any())

    @classmethod
    def nothing(cls, shape: tuple[int, int], kind: ElementKind) -> SegmentResult:
        """Empty masks of ``shape`` (H, W): the object is not visible."""
        z = np.zeros(shape, dtype=bool)
        return cls(z, z.copy(), kind, 0.0)


class Segmenter(ABC):
    """A segmentation backend. Stateless per call; cheap to call once per view and element."""

    @abstractmethod
    def segment(self, view: View, spec: ElementSpec, constraint_text: str = "") -> SegmentResult:
        """Segment ``spec.obj`` (and ``spec.part``) in ``view``.

        Args:
            view: one RGB-D view (rgb (H, W, 3) uint8, depth (H, W) metres, camera).
            spec: which object/part, and the element kind wanted.
            constraint_text: the constraint the element serves (a constraint-aware model uses it).
        Returns:
            masks (H, W) bool; empty when the object is not visible.
        Raises:
            PerceptionError: unknown object or part name, or a backend failure.
        """

    def segment_many(
        self, view: View, specs: list[ElementSpec], constraint_texts: list[str] | None = None
    ) -> list[SegmentResult]:
        """Segment several specs in one view (one result per spec, in order). The default calls
        :meth:`segment` for each; a backend that can do them in one pass overrides it."""
        texts = constraint_texts or [""] * len(specs)
        return [self.segment(view, s, t) for s, t in zip(specs, texts)]

    def robot_mask(self, view: View) -> np.ndarray | None:
        """(H, W) bool: the robot's own pixels in ``view`` (arm links and end effector), or None when this backend
        cannot tell (the default). The painter uses it to tell a part the robot hides from one that is absent;
        a real system gets it from a segmenter that knows the robot, or by rendering the robot's model at its
        joint state."""
        return None


# --- backend configs -----------------------------------------------------------------------------


@SegmenterConfig.register("sim")
@dataclass
class SimSegmenterConfig(SegmenterConfig):
    """Ground-truth masks from ``View.seg`` / ``View.seg_labels`` (simulator, or a pre-segmented log)."""


# Hue in OpenCV units (0-179), saturation and value 0-255: a colour is one or more (lo, hi) HSV boxes.
DEFAULT_COLORS: dict[str, list[tuple[tuple[int, int, int], tuple[int, int, int]]]] = {
    "red": [((0, 90, 50), (10, 255, 255)), ((170, 90, 50), (179, 255, 255))],
    "orange": [((11, 100, 80), (22, 255, 255))],
    "yellow": [((23, 90, 80), (35, 255, 255))],
    "green": [((36, 70, 40), (85, 255, 255))],
    "blue": [((95, 90, 40), (130, 255, 255))],
    "purple": [((131, 60, 40), (165, 255, 255))],
}


@SegmenterConfig.register("color")
@dataclass
class ColorSegmenterConfig(SegmenterConfig):
    """Classical colour + depth segmentation of coloured objects on a table.

    Attributes:
        colors: colour name -> list of HSV boxes ``((h, s, v) lo, (h, s, v) hi)``, OpenCV units
            (hue 0-179). An object name selects the colour it contains as a ``_``-separated token
            ("red_block" -> "red").
        object_colors: object name -> colour name, for names without a colour token ("zone": "green").
        flat_objects: objects lying flat on the table (marked zones): no table-plane removal.
        min_height: metres; pixels whose back-projected point is less than this above the dominant
            (table) plane are dropped. Used only when the view has depth.
        max_depth: metres; depth readings beyond this are ignored.
        plane_inlier: metres; RANSAC inlier distance when fitting the table plane.
        plane_iters: RANSAC iterations.
        plane_samples: how many valid depth pixels the plane fit samples.
        open_px, close_px: morphological opening / closing kernel sizes, pixels (0 disables).
        min_area_px: components smaller than this are ignored.
        multi_instance: keep every component above ``min_area_px`` instead of the largest one.
        top_band: metres; part "top" = object pixels within this of the object's highest point.
        seed: RANSAC random seed (deterministic masks).
    """

    colors: dict[str, list[tuple[tuple[int, int, int], tuple[int, int, int]]]] = field(
        default_factory=lambda: {k: list(v) for k, v in DEFAULT_COLORS.items()}
    )
    object_colors: dict[str, str] = field(default_factory=dict)
    flat_objects: tuple[str, ...] = ()
    min_height: float = 0.004
    max_depth: float = 5.0
    plane_inlier: float = 0.004
    plane_iters: int = 100
    plane_samples: int = 4000
    open_px: int = 3
    close_px: int = 5
    min_area_px: int = 30
    multi_instance: bool = False
    top_band: float = 0.008
    seed: int = 0

    def __post_init__(self) -> None:
        if not self.colors:
            raise ConfigError("color.colors must name at least one colour")
        bad = sorted(o for o, col in self.object_colors.items() if col not in self.colors)
        if bad:
            raise ConfigError(f"color.object_colors: {', '.join(bad)} map to colours not in color.colors")
        for f in ("min_height", "plane_inlier", "top_band"):
            check_positive("color", f, getattr(self, f), allow_zero=True)
        for f in ("plane_iters", "plane_samples", "max_depth"):
            check_positive("color", f, getattr(self, f))
        for f in ("open_px", "close_px", "min_area_px"):
            check_positive("color", f, getattr(self, f), allow_zero=True)


@SegmenterConfig.register("http")
@dataclass
class HttpSegmenterConfig(SegmenterConfig):
    """Client of a served segmentation model (wire format: :mod:`.http`).

    Attributes:
        url: endpoint URL the request is POSTed to, e.g. ``http://127.0.0.1:8500/segment``.
        timeout_s: per-request timeout, seconds.
        send_depth: also send the depth image (16-bit PNG, millimetres).
    """

    url: str = "http://127.0.0.1:8500/segment"
    timeout_s: float = 10.0
    send_depth: bool = False

    def __post_init__(self) -> None:
        if not self.url.startswith(("http://", "https://")):
            raise ConfigError(f"http.url must start with http:// or https://, got {self.url!r}")
        check_positive("http", "timeout_s", self.timeout_s)


_IMPLEMENTATIONS: dict[str, str] = {
    "sim": "code_as_monitor.perception.segmenters.sim:SimSegmenter",
    "color": "code_as_monitor.perception.segmenters.color:ColorSegmenter",
    "http": "code_as_monitor.perception.segmenters.http:HttpSegmenter",
}


def make_segmenter(config: SegmenterConfig) -> Segmenter:
    """Build the segmenter for ``config``, importing its implementation module only now."""
    return build_lazily(_IMPLEMENTATIONS, config, "segmenter")
