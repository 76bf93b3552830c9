"""Carry-over: an element the robot hides at a subgoal's start is taken from an earlier estimate of the same part,
when that estimate had more unhidden evidence and nothing in the views contradicts it.

At a subgoal's start the arm is often where the last skill left it: over the tower it just took a block from, or
holding the block above the next target. A part it hides is painted from the few pixels it leaves, and the
element can be centimetres off (:mod:`code_as_monitor.geometry.occlusion`). The agent remembers, per
``(object, part, kind)``, where its tracker last had each element (:class:`KnownElement`: the points, the cloud
moved with them, the support of the measurement they came from). :func:`carry_over` replaces a freshly painted
element by the remembered one when all of these hold:

1. the robot is involved: the fresh element's box is hidden by the robot over at least :data:`ROBOT_INVOLVED` of its
   pixels and the fresh element is weak (:meth:`~code_as_monitor.core.elements.ElementSupport.weak`), or the robot,
   or the object it holds, hides at least :data:`~code_as_monitor.core.elements.ROBOT_HIDDEN_WEAK` of the remembered
   cloud's projections (not counting those on the part itself) and either no view sees the part (the element is
   missing, or its whole object stands in for it: :func:`stands_in`) or the part's object is held. A held object
   turns with the robot and may hide its own part: a book turned upright in the gripper with its spine away from the
   cameras shows only the spine's 1 x 2.4 cm end, whose longest axis reads as a line across the book; its spine,
   remembered and turned with it, is behind the cover (the painter counts a held object's pixels as the robot's);
2. the remembered estimate rests on more evidence (:func:`evidence`): its points not hidden by the robot
   (``points x (1 - robot_hidden)``), capped, when a tracker moved it since it was measured, by the fewest
   observations the tracker reported its position resting on in any frame since
   (:attr:`~code_as_monitor.core.elements.ElementSupport.tracked`), outnumber the fresh element's. A paint is a
   measurement of hundreds of points; a tracker's estimate is only as good as the tracker: the oracle's motion is
   exact (no cap), a registration rests on the model points it saw, a 2-D point tracker on a few anchors, and a
   tracker that reports nothing on nothing (no carry-over of what it moved);
3. nothing contradicts it now (:func:`~code_as_monitor.geometry.occlusion.contradiction`): at most
   :data:`MAX_SEEN_THROUGH` of its cloud's projections are seen through (a view reads past where it would be) and
   at most :data:`MAX_OUTSIDE` of the part's visible points lie outside it.

Otherwise the fresh element stays (today's painting), its weakness in its support. With no robot mask (a segmenter
that cannot tell the robot) or nothing hidden, nothing is carried. Every decision is returned for the event log.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from code_as_monitor.core.elements import ROBOT_HIDDEN_WEAK, Element, ElementSpec, ElementSupport, color_for
from code_as_monitor.geometry.transforms import kabsch, rotation_onto

ROBOT_INVOLVED = 0.1
"""The fresh element's box must be hidden by the robot over at least this fraction for a carry-over to be tried (a
weak element the robot does not hide is weak for another reason: nothing remembered can fix that)."""
MAX_SEEN_THROUGH = 0.2
"""A remembered estimate is contradicted when the views see past more than this fraction of its cloud."""
MAX_OUTSIDE = 0.2
"""A remembered estimate is contradicted when more than this fraction of the part's visible points lie outside it."""

Key = tuple[str, str, str]
"""``(object, part, kind)``: what a remembered estimate is of."""


@dataclass(frozen=True)
class KnownElement:
    """An earlier estimate of one part, where the tracker last had it.

    Attributes:
        t: seconds, when the tracker last had it.
        points: (k, 3) world metres, the element's points then.
        cloud: (M, 3) world metres, the element's cloud moved with its points (None: none was painted).
        support: the support of the measurement the points came from (a carried element keeps its origin's), with
            ``tracked`` the fewest observations its tracker reported since that measurement (inf: none moved it, or
            the motion is exact).
    """

    t: float
    points: np.ndarray
    cloud: np.ndarray | None
    support: ElementSupport | None


def key_of(spec: ElementSpec) -> Key:
    """The remembered-estimate key of ``spec``."""
    return (spec.obj, spec.part, spec.kind.value)


def known_from(el: Element, points: np.ndarray, t: float, tracked: float = math.inf,
               rotation: np.ndarray | None = None) -> KnownElement:
    """What to remember of painted element ``el`` whose tracker last had it at ``points`` (k, 3) at time ``t``: its
    cloud moves by the points' mean displacement since painting. ``tracked``: the fewest observations the tracker
    reported the element's position resting on in any frame since ``el`` was measured (``inf``: ``points`` are the
    measurement, or the tracker's motion is exact); it caps the estimate's :func:`evidence`.

    The cloud moves rigidly with the points, turned as they turned (:func:`rotation_between`): a held book turned
    upright carries its painted skin upright with it (moved by the mean displacement alone, the skin of a book painted
    lying stayed lying across the upright book, and the views contradicted it: stow-book (c), seed 476548990).
    ``rotation`` (3, 3): the turn when it is known better than the element's own points tell (a line's two ends do
    not tell its turn about itself: :func:`object_rotations` fits it to all the elements of the object)."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cloud = None
    if el.cloud is not None and P.shape == el.points.shape and np.all(np.isfinite(P)):
        c0, c1 = el.points.mean(axis=0), P.mean(axis=0)
        R = rotation_between(el.points, P) if rotation is None else np.asarray(rotation, dtype=np.float64)
        cloud = (el.cloud - c0) @ R.T + c1
    support = el.support
    if support is not None:
        support = replace(support, tracked=min(float(tracked), support.tracked))
    return KnownElement(float(t), P.copy(), cloud, support)


def rotation_between(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(3, 3) the rotation that turns an element's points ``before`` (k, 3) into ``after`` (k, 3) about their means.

    One point: none (the identity). A line (2 points): the least rotation taking its old direction to its new one
    (a turn about the line itself cannot be seen from its two ends). Three or more: the best rigid fit (Kabsch).
    Points that coincide leave the identity."""
    A = np.asarray(before, dtype=np.float64).reshape(-1, 3)
    B = np.asarray(after, dtype=np.float64).reshape(-1, 3)
    if len(A) < 2 or A.shape != B.shape:
        return np.eye(3)
    if len(A) == 2:
        return rotation_onto(A[1] - A[0], B[1] - B[0])
    return kabsch(A, B)[0]


RIGID_TOL = 0.01
"""Metres: the elements of one object moved as one solid when the rotation fitted to all their points leaves none
further than this from where the tracker has it (about the wander of a painted centre on a half-hidden object)."""


def object_rotations(moves: Mapping[str, list[tuple[np.ndarray, np.ndarray]]]) -> dict[str, np.ndarray]:
    """Per object: (3, 3) the rotation its elements turned by, from ``moves`` (object -> [(points when measured (k, 3),
    points now (k, 3)), one per element]), fitted to all its elements' points together (:func:`rotation_between`);
    only for objects whose points span a plane (three not on one line) and moved as one solid (every point within
    :data:`RIGID_TOL` of the fit). Parts of one rigid object turn together: a book's centre point and its spine's two
    ends fix the book's turn, which the spine alone leaves open about itself."""
    out: dict[str, np.ndarray] = {}
    for obj, pairs in moves.items():
        A = np.vstack([np.asarray(a, dtype=np.float64).reshape(-1, 3) for a, _ in pairs])
        B = np.vstack([np.asarray(b, dtype=np.float64).reshape(-1, 3) for _, b in pairs])
        if len(A) < 3 or A.shape != B.shape or not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
            continue
        X = A - A.mean(axis=0)
        if np.linalg.svd(X, compute_uv=False)[1] < 1e-3:  # on one line (or one point): the turn about it is open
            continue
        R = rotation_between(A, B)
        if float(np.max(np.linalg.norm(X @ R.T + B.mean(axis=0) - B, axis=1))) <= RIGID_TOL:
            out[obj] = R
    return out


def evidence(support: ElementSupport | None) -> float:
    """The points an estimate rests on that the robot did not hide, ``points x (1 - robot_hidden)``, and no more than
    the fewest observations a tracker that moved it since reported (``support.tracked``); 0 without a support."""
    if support is None:
        return 0.0
    return min(float(support.points) * (1.0 - float(support.robot_hidden)), float(support.tracked))


@dataclass
class CarryDecision:
    """One carry-over decision for the event log: element ``id``/``name``, whether it was ``carried``, why
    (``reason``), and the figures it rests on."""

    id: int
    name: str
    carried: bool
    reason: str
    figures: dict

    def to_dict(self) -> dict:
        return {"id": self.id, "name": self.name, "carried": self.carried, "reason": self.reason, **self.figures}


def stands_in(fresh: Element | None) -> bool:
    """Whether ``fresh`` is a part's element painted from its whole object (no view showed the part:
    ``support.part_seen`` False): no view sees the part, as when it is missing (condition 1)."""
    return fresh is not None and bool(fresh.owner[1]) and fresh.support is not None and not fresh.support.part_seen


def candidate(fresh: Element | None) -> bool:
    """Whether a carry-over may be tried for ``fresh`` (condition 1 of the module docstring, for a painted one;
    a missing one, or a part's whole object standing in for it, is decided on the remembered cloud)."""
    if fresh is None or stands_in(fresh):
        return True
    sup = fresh.support
    return sup is not None and sup.robot_hidden >= ROBOT_INVOLVED and sup.weak()


def decide(eid: int, spec: ElementSpec, fresh: Element | None, known: KnownElement,
           seen_through: float, outside: float, robot_hidden_known: float) -> tuple[Element | None, CarryDecision]:
    """The element to use for ``spec`` (id ``eid``) and the decision, given the contradiction figures of the
    remembered estimate ``known`` (:func:`~code_as_monitor.geometry.occlusion.contradiction`) and the fraction of
    its cloud the robot (or what it holds) hides now, not counting the part seen now (condition 1)."""
    unseen = fresh is None or stands_in(fresh)  # no view sees the part (condition 1)
    fresh_support = None if unseen else fresh.support  # a stand-in is no evidence of where the part is (2)
    fig = {"from_t": round(known.t, 3), "seen_through": round(seen_through, 3), "outside": round(outside, 3),
           "evidence_known": round(evidence(known.support), 1), "evidence_fresh": round(evidence(fresh_support), 1)}
    if known.support is not None and math.isfinite(known.support.tracked):
        fig["tracked_known"] = round(known.support.tracked, 1)  # the tracker's weakest frame capped it
    if fresh is not None and fresh.support is not None:
        fig["robot_hidden"] = round(fresh.support.robot_hidden, 3)
        fig["shift"] = round(float(np.linalg.norm(fresh.points.mean(axis=0) - known.points.mean(axis=0))), 4)
    fig["robot_hidden_known"] = round(robot_hidden_known, 3)
    hidden_fresh = fresh is not None and candidate(fresh)

    def keep(reason: str) -> tuple[Element | None, CarryDecision]:
        return fresh, CarryDecision(eid, spec.name, False, reason, fig)

    if unseen and robot_hidden_known < ROBOT_HIDDEN_WEAK:
        return keep("no view sees it and the robot does not hide where it was")
    if fresh is not None and not hidden_fresh and robot_hidden_known < ROBOT_HIDDEN_WEAK:
        return keep("the robot hides neither the fresh element nor, with what it holds, where the part was")
    if fresh is not None and known.points.shape != fresh.points.shape:
        return keep("the remembered estimate has another shape")
    if not np.all(np.isfinite(known.points)):
        return keep("the remembered estimate is not finite")
    if evidence(known.support) <= evidence(fresh_support):
        if known.support is not None and known.support.tracked < evidence(replace(known.support, tracked=math.inf)):
            return keep("the remembered estimate rests on no more than the fresh one: its tracker's weakest frame "
                        f"since it was measured had {known.support.tracked:.0f} observations")
        return keep("the remembered estimate rests on no more unhidden points than the fresh one")
    if seen_through > MAX_SEEN_THROUGH:
        return keep(f"the views see past {seen_through:.0%} of the remembered estimate (it moved)")
    if outside > MAX_OUTSIDE:
        return keep(f"{outside:.0%} of the visible points lie outside the remembered estimate (it moved)")
    sup = replace(known.support, carried=True) if known.support is not None else None
    el = Element(eid, spec.name, spec.kind, known.points.copy(), (spec.obj, spec.part), color_for(eid),
                 cloud=None if known.cloud is None else known.cloud.copy(), support=sup)
    el.object_cloud = el.cloud if (fresh is None or fresh.object_cloud is None or not spec.part) else fresh.object_cloud
    why = "the robot hides it" if fresh is None or hidden_fresh else "what the robot holds hides it"
    return el, CarryDecision(eid, spec.name, True, f"{why}; the remembered estimate is not contradicted", fig)


def carry_over(built: dict[int, Element | None], specs: Mapping[int, ElementSpec], known: Mapping[Key, KnownElement],
               figures: Mapping[int, tuple[float, float, float]]) -> tuple[dict[int, Element | None],
                                                                         list[CarryDecision]]:
    """Apply :func:`decide` to every element with a remembered estimate whose contradiction figures
    ``(seen_through, outside, robot_hidden_known)`` were measured (the painter measures them for the candidates).
    Returns the elements (carried ones replaced) and the decisions."""
    out = dict(built)
    decisions = []
    for eid, fig in figures.items():
        spec = specs[eid]
        k = known.get(key_of(spec))
        if k is None:
            continue
        out[eid], d = decide(eid, spec, built.get(eid), k, *fig)
        decisions.append(d)
    return out, decisions


__all__ = ["MAX_OUTSIDE", "MAX_SEEN_THROUGH", "ROBOT_INVOLVED", "CarryDecision", "KnownElement", "candidate",
           "carry_over", "decide", "evidence", "key_of", "known_from", "object_rotations",
           "rotation_between", "stands_in"]
