"""Constraint elements: the compact geometric abstraction (points, lines, surfaces) the monitor reasons on.

All points are in the world frame, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from code_as_monitor.core.errors import ElementError

# Distinct, readable colours (RGB uint8) for element ids 0, 1, 2, ... (cycled).
PALETTE: tuple[tuple[int, int, int], ...] = (
    (230, 25, 75), (60, 180, 75), (0, 130, 200), (245, 130, 48), (145, 30, 180),
    (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212), (0, 128, 128),
    (220, 190, 255), (170, 110, 40), (255, 250, 200), (128, 0, 0), (170, 255, 195),
    (128, 128, 0), (255, 215, 180), (0, 0, 128), (255, 225, 25), (128, 128, 128),
)


class ElementKind(str, Enum):
    """Kind of a constraint element and the number of points it carries."""

    POINT = "point"  # 1 point
    LINE = "line"  # 2 points: the ends along the principal axis
    SURFACE = "surface"  # 3 or 4 non-collinear points spanning the fitted plane

    @classmethod
    def parse(cls, value: str | ElementKind) -> ElementKind:
        """Parse ``value``; raise ElementError naming it when it is not a kind."""
        if isinstance(value, ElementKind):
            return value
        try:
            return cls(str(value).strip().lower())
        except ValueError:
            raise ElementError(
                f"unknown element kind {value!r}; expected one of: point, line, surface"
            ) from None

    @property
    def min_points(self) -> int:
        return {"point": 1, "line": 2, "surface": 3}[self.value]

    @property
    def max_points(self) -> int:
        return {"point": 1, "line": 2, "surface": 4}[self.value]


@dataclass(frozen=True)
class ElementSpec:
    """What an element should abstract: a part of an object, as a kind.

    Attributes:
        name: short name used in the legend and code comments ("red block top", "pen axis").
        obj: object name in the scene ("red_block", "teapot", "robot").
        part: part name ("" for the whole object; "top", "spout", "tip", ...).
        kind: the element kind.
    """

    name: str
    obj: str
    part: str = ""
    kind: ElementKind = ElementKind.POINT

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", ElementKind.parse(self.kind))

    def to_dict(self) -> dict:
        return {"name": self.name, "obj": self.obj, "part": self.part, "kind": self.kind.value}

    @classmethod
    def from_dict(cls, d: dict) -> ElementSpec:
        return cls(d["name"], d["obj"], d.get("part", ""), ElementKind.parse(d.get("kind", "point")))


MAX_CLOUD_POINTS = 2000
"""The most points an element's ``cloud`` / ``object_cloud`` carries (the painter voxel-downsamples to it)."""


ROBOT_HIDDEN_WEAK = 0.3
"""An element whose box the robot hides over more than this fraction of its pixels (all views together) was painted
mostly through the robot: weak (:meth:`ElementSupport.weak`), and the painter may carry an earlier estimate over."""


@dataclass(frozen=True)
class ElementSupport:
    """How well the observations supported an element: what checks and the agent read to tell a weak one.

    Attributes:
        points: number of cloud points (after fusion, downsampling and outlier removal) the fit used.
        views: number of views whose mask contributed at least one valid depth reading.
        residual: metres; RMS distance of those points to the fitted model (which model depends on the
            kind: see :mod:`code_as_monitor.geometry.elements`), i.e. how well the model explains them.
        spread: metres; half the largest extent of the cloud (how big the part looked).
        extent: (3,) metres; the part's fitted size along its own axes (largest first).
        assumed: how many sides of the part's box no view bounded: their depth is an assumption (as deep as the
            smaller of the part's other two extents: a compact solid), not a measurement (a block under another one
            seen from the front only; a block in a tower seen on one face alone).
        part_seen: False when no view saw the element's part and the whole object's masks stood in for it.
        robot_hidden: fraction (0..1) of the pixels the part's box covers in the views where the robot's own body
            is in front of it (0 when the segmenter cannot tell the robot): an element painted mostly through the
            robot (over :data:`ROBOT_HIDDEN_WEAK`) is weak, however many points it has.
        carried: True when the element is not this paint's measurement but an earlier estimate of the same part,
            carried over because the robot hid the part and nothing in the views contradicted the estimate.
        tracked: for a carried element, the fewest observations (3-D points, anchors) a tracker reported its
            position resting on in any frame since it was last measured (``inf``: it is a measurement, or it was
            moved by a tracker whose motion is exact, the oracle's): a tracked estimate is no better supported than
            its tracker's weakest frame (:func:`~code_as_monitor.painter.carry_over.evidence`).
        uncertainty: metres; how far the views let the element's centre lie from where it is painted because of
            its assumed sides, or sides that may go on behind a sibling part's surface
            (:attr:`code_as_monitor.geometry.solid.Box.uncertainty`); 0 when a view bounds every side (then only
            the depth noise and the fit, ``residual``, limit it). It does not make the element weak.
        direction_seen: False for a line whose points do not show its part long along it
            (:func:`~code_as_monitor.geometry.elements.seen_lengthwise`): the views show a stub of the part (a book's
            spine seen by its top end above the shelf), and its longest axis, the line's direction, is whichever way
            the stub's outline and the depth noise make longest. Such a line is weak.
    """

    points: int
    views: int
    residual: float
    spread: float = 0.0
    extent: tuple[float, float, float] = (0.0, 0.0, 0.0)
    assumed: int = 0
    part_seen: bool = True
    robot_hidden: float = 0.0
    carried: bool = False
    tracked: float = math.inf
    uncertainty: float = 0.0
    direction_seen: bool = True

    def to_dict(self) -> dict:
        d = {"points": self.points, "views": self.views, "residual": round(self.residual, 5),
             "spread": round(self.spread, 5), "extent": [round(float(x), 5) for x in self.extent],
             "assumed": self.assumed, "part_seen": self.part_seen, "robot_hidden": round(self.robot_hidden, 3),
             "carried": self.carried, "uncertainty": round(self.uncertainty, 4)}
        if math.isfinite(self.tracked):  # JSON has no infinity: absent means a measurement
            d["tracked"] = round(float(self.tracked), 3)
        if not self.direction_seen:  # absent: seen (points, surfaces, elongated lines)
            d["direction_seen"] = False
        return d

    @classmethod
    def from_dict(cls, d: dict) -> ElementSupport:
        ext = tuple(float(x) for x in d.get("extent", (0.0, 0.0, 0.0)))
        return cls(int(d["points"]), int(d["views"]), float(d["residual"]), float(d.get("spread", 0.0)),
                   (ext[0], ext[1], ext[2]), int(d.get("assumed", 0)), bool(d.get("part_seen", True)),
                   float(d.get("robot_hidden", 0.0)), bool(d.get("carried", False)),
                   float(d.get("tracked", math.inf)), float(d.get("uncertainty", 0.0)),
                   bool(d.get("direction_seen", True)))

    def weak(self, min_points: int = 20, min_views: int = 1, max_residual: float = 0.004,
             max_robot_hidden: float | None = None) -> bool:
        """True when fewer than ``min_points`` points or ``min_views`` views supported the element, its fit
        residual exceeds ``max_residual`` metres, a side of its box was assumed, its part was not seen, the robot
        hid more than ``max_robot_hidden`` (default :data:`ROBOT_HIDDEN_WEAK`) of it, or it is a line whose direction
        the views leave open (``direction_seen`` False)."""
        limit = ROBOT_HIDDEN_WEAK if max_robot_hidden is None else max_robot_hidden
        return (self.points < min_points or self.views < min_views or self.residual > max_residual
                or self.assumed > 0 or not self.part_seen or self.robot_hidden > limit or not self.direction_seen)


@dataclass
class Element:
    """One constraint element.

    Attributes:
        id: the number drawn on the images; stable within a subgoal.
        name: legend name.
        kind: point | line | surface.
        points: (k, 3) world frame, metres; k = 1 (point), 2 (line), 3-4 (surface).
        owner: (object, part) it abstracts.
        color: (3,) RGB uint8 used to draw it.
        cloud: optional (M, 3) world points (metres) of the owner's segmented mask (the part's mask when
            the element has a part, else the instance's) over all views at paint time, voxel-downsampled
            to at most :data:`MAX_CLOUD_POINTS`; ``None`` for elements not built from masks (the robot's).
            A depth tracker registers it to new frames; the element's points move with it.
        object_cloud: optional (M, 3) world, metres: the same for the whole object instance (the same
            array as ``cloud`` for a whole-object element).
        support: optional :class:`ElementSupport` (points, views, fit residual) of the estimate.

    ``cloud``, ``object_cloud`` and ``support`` are left out of equality; :meth:`to_dict` writes the
    support and only the clouds' point counts (events stay small).
    """

    id: int
    name: str
    kind: ElementKind
    points: np.ndarray
    owner: tuple[str, str] = ("", "")
    color: tuple[int, int, int] = field(default=(255, 255, 255))
    cloud: np.ndarray | None = field(default=None, repr=False, compare=False)
    object_cloud: np.ndarray | None = field(default=None, repr=False, compare=False)
    support: ElementSupport | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        self.cloud = _check_cloud(self.cloud, self.name, "cloud")
        self.object_cloud = _check_cloud(self.object_cloud, self.name, "object_cloud")
        self.kind = ElementKind.parse(self.kind)
        pts = np.asarray(self.points, dtype=np.float64)
        if pts.ndim == 1 and pts.shape == (3,):
            pts = pts[None]
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ElementError(f"element {self.name!r}: points must be (k, 3), got {pts.shape}")
        k = pts.shape[0]
        if not self.kind.min_points <= k <= self.kind.max_points:
            raise ElementError(
                f"element {self.name!r}: a {self.kind.value} needs {self.kind.min_points}"
                f"-{self.kind.max_points} points, got {k}"
            )
        if not np.all(np.isfinite(pts)):
            raise ElementError(f"element {self.name!r}: points contain NaN or inf")
        if self.kind is ElementKind.LINE and np.linalg.norm(pts[1] - pts[0]) < 1e-9:
            raise ElementError(f"element {self.name!r}: line end points coincide")
        if self.kind is ElementKind.SURFACE:
            centred = pts - pts.mean(axis=0)
            sv = np.linalg.svd(centred, compute_uv=False)
            if sv.shape[0] < 2 or sv[1] < 1e-9:
                raise ElementError(f"element {self.name!r}: surface points are collinear")
        self.points = pts

    # --- constructors -------------------------------------------------------------------------
    @classmethod
    def point(cls, id: int, name: str, p: np.ndarray, owner: tuple[str, str] = ("", ""), **kw) -> Element:
        """A point element at ``p`` (3,), world metres."""
        return cls(id, name, ElementKind.POINT, np.asarray(p, dtype=np.float64).reshape(1, 3), owner, **_col(id, kw))

    @classmethod
    def line(
        cls, id: int, name: str, p0: np.ndarray, p1: np.ndarray, owner: tuple[str, str] = ("", ""), **kw
    ) -> Element:
        """A line element from ``p0`` to ``p1`` (3,) each, world metres."""
        return cls(id, name, ElementKind.LINE, np.stack([p0, p1]).astype(np.float64), owner, **_col(id, kw))

    @classmethod
    def surface(cls, id: int, name: str, pts: np.ndarray, owner: tuple[str, str] = ("", ""), **kw) -> Element:
        """A surface element from 3-4 non-collinear points (k, 3), world metres, in boundary order."""
        return cls(id, name, ElementKind.SURFACE, np.asarray(pts, dtype=np.float64), owner, **_col(id, kw))

    def centroid(self) -> np.ndarray:
        """(3,) mean of the element's points."""
        return self.points.mean(axis=0)

    def moved(self, points: np.ndarray) -> Element:
        """A copy at ``points`` (k, 3) world, keeping the clouds, support and everything else."""
        return replace(self, points=points)

    def to_dict(self) -> dict:
        d = {
            "id": self.id,
            "name": self.name,
            "kind": self.kind.value,
            "points": self.points.round(5).tolist(),
            "owner": list(self.owner),
            "color": list(self.color),
        }
        if self.support is not None:
            d["support"] = self.support.to_dict()
        if self.cloud is not None:
            d["cloud_points"] = len(self.cloud)
        if self.object_cloud is not None:
            d["object_cloud_points"] = len(self.object_cloud)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Element:
        """Inverse of :meth:`to_dict` (the clouds are not serialised: they come back as ``None``)."""
        sup = d.get("support")
        return cls(
            int(d["id"]), d["name"], ElementKind.parse(d["kind"]), np.array(d["points"]),
            tuple(d.get("owner", ("", ""))), tuple(d.get("color", (255, 255, 255))),
            support=None if sup is None else ElementSupport.from_dict(sup),
        )


def stood_in(old: Element, new: Element) -> bool:
    """Whether a re-painted ``new`` of the part element ``old`` is its whole object standing in for a part
    that ``old`` had seen (``support.part_seen``): not the part's position (a pen's tip re-painted while
    the holder hides it is the visible pen above the holder, 8 cm off, slot-pen seed 1308640672)."""
    was, now = old.support, new.support
    return bool(old.owner[1]) and now is not None and not now.part_seen and (was is None or was.part_seen)


def color_for(element_id: int) -> tuple[int, int, int]:
    """The palette colour for an element id."""
    return PALETTE[element_id % len(PALETTE)]


def _check_cloud(cloud: np.ndarray | None, name: str, what: str) -> np.ndarray | None:
    if cloud is None:
        return None
    C = np.asarray(cloud, dtype=np.float64)
    if C.ndim != 2 or C.shape[1] != 3:
        raise ElementError(f"element {name!r}: {what} must be (M, 3), got {C.shape}")
    if not np.all(np.isfinite(C)):
        raise ElementError(f"element {name!r}: {what} contains NaN or inf")
    return C


def _col(id: int, kw: dict) -> dict:
    kw = dict(kw)
    kw.setdefault("color", color_for(id))
    return kw
