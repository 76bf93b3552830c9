"""Tracking by detection: the depth tracker's mode for bodies too small to register (the blocks of a
pushed pile, the beads of a rope).

Why. Point-to-plane ICP needs a model with enough points to pin six degrees of freedom, and a
correspondence reach shorter than the body: a rope bead's painted cloud is 10-20 points after the
tracker's 3 mm voxel grid (small_gicp warns below 10), and a 2 cm block is no bigger than the first ICP
round's 2 cm correspondence distance, so in a pile its registration can slide onto an identical
neighbour that fits as well.

Which bodies (:func:`is_small`), measured on the body's painted cloud after the tracker's voxel grid (the
registration model :class:`.depth_body.RigidBody`): fewer than ``detect_points`` points, or a largest
principal extent of at most ``detect_extent`` metres. A small *part* of an object that has another element
large enough to register (a pen's tip beside its shaft) stays registered, with its object's motion among
its guesses, as before: it is rigid with something trackable. The parts of an object whose painted
elements are all small (a rope's beads) are tracked by detection. Nothing names a task or an object. Only when the
tracker has a segmenter (:meth:`.base.Tracker.set_segmenter`; the agent passes the painter's); without one
every body is registered.

Per frame (:func:`track_small`):

1. detect (:func:`.depth_detections.detect`): the segmenter is asked, through the interface the painter uses
   (``segment_many(view, specs)``), for every small body's spec in every usable view; each mask with at
   least ``detect_min_pixels`` valid depth pixels is lifted (:class:`~code_as_monitor.geometry.backproject.LiftedView`)
   to the centroid of its points (world metres). **Detections are anonymous**: which query produced a mask
   is dropped, and a view's detections are a set of centroids sorted by position. A real segmenter (ConSeg,
   an open-vocabulary detector) does not keep the identity of identical beads or blocks from one frame to
   the next; the ``sim`` segmenter does, and that identity is thrown away here so the tracker never relies
   on it. Views are not matched to each other either: each view is associated on its own (3).
2. predict each body's *reference point* (its elements' centroid when painted, carried since): a held body
   (the tip within ``held_distance`` plus half its extent while the gripper or suction is on) moves with
   the end effector; any other has up to three hypotheses: where it was, moved at its last velocity, and
   moved by the tool tip's step since the last frame when the tip passed near it or near a body so moved
   (ahead of it for a push, any side while the gripper or suction is on: a dragged rope follows);
   ``detect_chain`` sets "near". A pair's distance is to the nearest hypothesis.
3. associate, per view: detection ``j`` stands for body ``i`` at its centroid plus the body's *offset* in
   that view (its reference point minus its centroid there when it was painted: the side the view sees,
   turned with the direction to the camera, :func:`estimates`); the one-to-one assignment of least total
   distance (scipy's ``linear_sum_assignment``), with "no detection" allowed, never a pair outside the
   body's gate nor of another colour (chromaticity further than ``detect_chroma`` from the body's). First
   the bodies tracked last frame, with a gate of ``detect_gate`` times the body's extent; then the lost
   ones, from the detections left, with a gate growing by two extents per lost frame up to
   ``detect_reacquire_gate`` extents (re-acquisition: the objects are anonymous, so a detection of their
   colour that no tracked body takes is one of the lost ones; a lost body held by the end effector, or
   dragged with a held one, is searched where the end effector's motion takes it).
   The gate, one extent. Identical solid objects cannot overlap, so an identical neighbour's centre is
   about one extent away or more: the gate keeps a body from jumping onto a neighbour when its own
   detection is missing, and it is wider than the residual of a good prediction (a block or bead moving
   steadily, or with the tool). Two identical beads passing close keep their identities while each is
   seen near its prediction: the assignment takes the least total distance. Identities of identical
   objects are NOT kept when they move further than their own size between frames in ways no hypothesis
   predicts (a pile pushed at 45 mm per frame, a rope whipped by a 10 Hz drag): the positions of the set
   stay right, which body of the set is where may swap. A tracked body never loses its detection to a
   lost one (tracked bodies are matched first).
4. a body matched in at least one view is at the mean of its matched views' estimates, from the views
   where nothing nearer borders its mask when there are such views (a partly occluded mask's centroid is
   pulled towards its visible part); a view whose offset is not known yet uses the median offset of the
   other small bodies there, and learns its own from this frame. Its elements' points translate with it
   (a small body's rotation is not estimated). A body matched in no view is *lost* this frame: its
   elements are stale, at their last good points, nothing guessed. Lost bodies are re-acquired by step 3
   only: the painter's re-segmentation hook, which asks the segmenter by name, is not used for them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.elements import Element, ElementSpec
from code_as_monitor.core.errors import CamError
from code_as_monitor.perception.trackers.base import DepthTrackerConfig
from code_as_monitor.perception.trackers.depth_body import RigidBody
from code_as_monitor.perception.trackers.depth_detections import ViewDetections
from code_as_monitor.perception.trackers.depth_views import Plane

Owner = tuple[str, str]
NO_MATCH = 1e6  # cost of a pair outside its gate (never chosen over "no detection")


@dataclass
class SmallBody:
    """Tracking state of one small body (followed by detection).

    Attributes:
        owner: (object, part).
        spec: what the segmenter is asked for (object, part, kind).
        extent: metres, the largest principal extent of its painted cloud.
        position: (3,) world metres, its reference point at its last good frame.
        velocity: (3,) m/s, from its last two good frames (zero after a lost frame).
        offsets: view name -> ((3,) reference point minus the body's detected centroid in that view, (3,) unit
            direction from that centroid to the camera then).
        chroma: (3,) the chromaticity (R, G, B) / (R + G + B) of its detection when first seen: a detection
            of another colour is not this body (identical objects share it; a rope's bead is not a corner).
        t: observation time of ``position``.
    """

    owner: Owner
    spec: ElementSpec
    extent: float
    position: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    offsets: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    chroma: np.ndarray | None = None  # (3,) its colour's chromaticity when first detected
    t: float = 0.0
    lost: bool = False
    lost_frames: int = 0
    held: bool = False
    seen_views: int = 0
    elements: list[int] = field(default_factory=list)


def principal_extent(points: np.ndarray) -> float:
    """Largest extent (metres) of ``points`` (N, 3) along their principal axes; 0 for fewer than 2 points."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(P) < 2:
        return 0.0
    P = P - P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P, full_matrices=False)
    Q = P @ Vt[0]
    return float(Q.max() - Q.min())


def is_small(model_points: np.ndarray, c: DepthTrackerConfig) -> bool:
    """Whether a body whose registration model has ``model_points`` (N, 3) is too small to register."""
    return len(model_points) < c.detect_points or principal_extent(model_points) <= c.detect_extent


def model_points(cloud: np.ndarray, c: DepthTrackerConfig, plane: Plane | None) -> np.ndarray:
    """(N, 3) the points a body painted from ``cloud`` would register (its finite points when too few)."""
    try:
        return RigidBody(cloud, c.voxel, plane, c.plane_band, c.min_points, c.max_model_points).points
    except CamError:  # fewer points than registration needs at all
        pts = np.asarray(cloud, dtype=np.float64).reshape(-1, 3)
        return pts[np.isfinite(pts).all(axis=1)]


def registrable_objects(elements: Sequence[Element], c: DepthTrackerConfig, plane: Plane | None) -> set[str]:
    """Objects with at least one painted element whose cloud is not too small to register (their small
    parts stay registered with them). A part element that no view saw, built from its whole object's masks
    instead (``support.part_seen`` False), does not count: its cloud is not the part's."""
    out: set[str] = set()
    for el in elements:
        support = getattr(el, "support", None)
        if el.owner[1] and support is not None and not support.part_seen:
            continue
        cloud = getattr(el, "cloud", None)
        if cloud is None or not len(cloud):
            cloud = getattr(el, "object_cloud", None) if not el.owner[1] else None
        if el.owner[0] not in c.kinematic_owners and cloud is not None and len(cloud) \
                and el.owner[0] not in out and not is_small(model_points(cloud, c, plane), c):
            out.add(el.owner[0])
    return out


def _assign(pred: list[np.ndarray], cand: list[np.ndarray], gates: np.ndarray,
            alike: np.ndarray | None = None) -> list[int]:
    """For each body ``i``, the index of its detection or -1.

    ``pred[i]`` (h, 3): the body's predicted positions (hypotheses); ``cand[i]`` (m, 3): every detection as
    an estimate of body ``i``'s reference point (centroid + the body's offset). A pair's distance is to
    the nearest hypothesis. One-to-one: as many pairs as the gates allow, then the least total distance
    (every body may take "no detection" at the same cost, the largest gate; a body's own gate does not
    make it more eager: a body lost for long must not win a detection over a nearer one lost just now);
    no pair further apart than its gate is made, nor a pair ``alike`` (n, m) bool says
    differ in colour.
    """
    from scipy.optimize import linear_sum_assignment

    n = len(pred)
    m = len(cand[0]) if n else 0
    if n == 0 or m == 0:
        return [-1] * n
    D = np.stack([np.linalg.norm(cand[i][:, None] - pred[i][None], axis=2).min(axis=1) for i in range(n)])
    cost = np.full((n, m + n), NO_MATCH)
    inside = np.less_equal(D, gates[:, None])
    if alike is not None:
        inside &= alike
    cost[:, :m] = np.where(inside, D, NO_MATCH)
    cost[np.arange(n), m + np.arange(n)] = float(gates.max())  # the same for all: least total distance
    rows, cols = linear_sum_assignment(cost)
    out = [-1] * n
    for r, col in zip(rows, cols):
        if col < m and inside[r, col]:
            out[r] = int(col)
    return out


def _offset(body: SmallBody, view: str, bodies: Sequence[SmallBody]) -> tuple[np.ndarray, np.ndarray] | None:
    """The body's offset in ``view``: its own, else the median of the other small bodies' there, else None."""
    own = body.offsets.get(view)
    if own is not None:
        return own
    return _median_offset(view, bodies)


def _median_offset(view: str, bodies: Sequence[SmallBody]) -> tuple[np.ndarray, np.ndarray] | None:
    """The median of the offsets of ``bodies`` in ``view`` (what a body without its own there adopts), else None."""
    others = [b.offsets[view] for b in bodies if view in b.offsets]
    if not others:
        return None
    d = np.median(np.array([o[1] for o in others]), axis=0)
    return np.median(np.array([o[0] for o in others]), axis=0), d / max(float(np.linalg.norm(d)), 1e-12)


def estimates(C: np.ndarray, eye: np.ndarray, offset: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """Reference points (m, 3) that the centroids ``C`` (m, 3) seen from the camera at ``eye`` (3,) stand for.

    A view sees the side of a small object that faces it, so its centroid lies towards the camera from the
    object's reference point. The offset measured when the body was painted (``o``, with ``d0`` the unit
    direction to the camera then) is turned by the rotation taking ``d0`` to the centroid's direction to
    the camera now: exact for a sphere, and for a block as far as its visible faces do not change.
    """
    if offset is None:
        return C.copy()
    o, a = offset
    b = eye - C
    b = b / np.maximum(np.linalg.norm(b, axis=1, keepdims=True), 1e-12)
    v = _cross(a, b)
    c = b @ a
    rot = o * c[:, None] + _cross(v, o) + v * ((v @ o) / np.maximum(1.0 + c, 1e-9))[:, None]
    return C + rot


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of 3-vectors along the last axis (broadcast), by the same products in the same order, without
    its per-call overhead (it dominated the association of many small bodies)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def associate(bodies: Sequence[SmallBody], pred: list[np.ndarray], det: dict[str, ViewDetections],
              gates: np.ndarray, max_chroma: float,
              taken: dict[str, set[int]] | None = None) -> dict[int, dict[str, int]]:
    """Body index -> {view: detection index} for the bodies ``bodies`` (hypotheses ``pred[i]`` (h, 3), gates
    (n,) metres), each view on its own; detections in ``taken[view]`` are not offered (and the ones matched
    here are added to it)."""
    taken = taken if taken is not None else {}
    out: dict[int, dict[str, int]] = {i: {} for i in range(len(bodies))}
    for view, vd in det.items():
        used = taken.setdefault(view, set())
        free = [j for j in range(len(vd.centroids)) if j not in used]
        if not free or not len(bodies):
            continue
        Cf = vd.centroids[free]
        median = _median_offset(view, bodies)  # once per view: the fallback of every body without its own
        cand = [estimates(Cf, vd.eye, b.offsets.get(view, median)) for b in bodies]
        alike = _alike(bodies, vd.chroma[free], max_chroma)
        for i, j in enumerate(_assign(pred, cand, gates, alike)):
            if j >= 0:
                out[i][view] = free[j]
                used.add(free[j])
    return out


def _alike(bodies: Sequence[SmallBody], chroma: np.ndarray, max_chroma: float) -> np.ndarray:
    """(n, m) bool: detection ``j``'s chromaticity is within ``max_chroma`` of body ``i``'s (True for a body
    whose colour is not known yet)."""
    out = np.ones((len(bodies), len(chroma)), dtype=bool)
    for i, b in enumerate(bodies):
        if b.chroma is not None and max_chroma > 0:
            out[i] = np.linalg.norm(chroma - b.chroma, axis=1) <= max_chroma
    return out


def init_offsets(bodies: Sequence[SmallBody], det: dict[str, ViewDetections], gate: float) -> None:
    """At paint time: each body's offset in each view, from the detection nearest its reference point
    (one-to-one, within ``gate`` times its extent)."""
    if not bodies:
        return
    pred = [b.position[None] for b in bodies]
    gates = np.array([gate * b.extent for b in bodies])
    for view, vd in det.items():
        for i, j in enumerate(_assign(pred, [vd.centroids] * len(bodies), gates)):
            if j >= 0:
                bodies[i].offsets[view] = _measured(bodies[i].position, vd.centroids[j], vd.eye)
                if bodies[i].chroma is None:
                    bodies[i].chroma = vd.chroma[j].copy()


def _measured(ref: np.ndarray, centroid: np.ndarray, eye: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = eye - centroid
    return ref - centroid, d / max(float(np.linalg.norm(d)), 1e-12)


def track_small(c: DepthTrackerConfig, bodies: Sequence[SmallBody], det: dict[str, ViewDetections], t: float,
                dT_ee: np.ndarray | None, tips: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """One frame of every small body from the frame's anonymous detections ``det`` (see the module
    docstring). ``dT_ee``: the end effector's motion since the last frame (4, 4, world), for held bodies;
    ``tips``: the tool tip (3,) at the last frame and now, for pushed ones."""
    if not bodies:
        return
    pushed = _pushed(bodies, tips, c.detect_chain, dT_ee is not None) if tips is not None else set()
    step = tips[1] - tips[0] if tips is not None else np.zeros(3)
    pred = [_predict(b, t, dT_ee, step if i in pushed else None) for i, b in enumerate(bodies)]
    taken: dict[str, set[int]] = {}
    tracked = [i for i, b in enumerate(bodies) if not b.lost]
    lost = [i for i, b in enumerate(bodies) if b.lost]
    matches: dict[int, dict[str, int]] = {}
    for group, gates in (
        (tracked, np.array([c.detect_gate * bodies[i].extent for i in tracked])),
        (lost, np.array([min(c.detect_reacquire_gate, c.detect_gate + 2 * bodies[i].lost_frames) * bodies[i].extent
                         for i in lost])),
    ):
        sub = [bodies[i] for i in group]
        found = associate(sub, [pred[i] for i in group], det, gates, c.detect_chroma, taken)
        matches.update({group[k]: v for k, v in found.items()})
    for i, b in enumerate(bodies):
        m = matches.get(i, {})
        if not m:
            b.lost, b.lost_frames, b.seen_views, b.velocity = True, b.lost_frames + 1, 0, np.zeros(3)
            if b.held and dT_ee is not None:  # searched where the end effector takes it (not reported)
                b.position = dT_ee[:3, :3] @ b.position + dT_ee[:3, 3]
            elif i in pushed and dT_ee is not None:  # dragged along with a held neighbour: searched there too
                b.position = b.position + step
            continue
        known = {v: j for v, j in m.items() if v in b.offsets}
        if not known:  # never matched where it was painted: it adopts its kind's offsets in these views
            for v in m:
                off = _offset(b, v, bodies)
                b.offsets[v] = off if off is not None else (np.zeros(3), np.array([0.0, 0.0, 1.0]))
            known = dict(m)
        whole = {v: j for v, j in known.items() if not det[v].truncated[j]}
        use = whole or known  # views that see the whole object, when there are any
        est = np.mean([estimates(det[v].centroids[j][None], det[v].eye, b.offsets[v])[0] for v, j in use.items()],
                      axis=0)
        for v, j in m.items():
            if v not in b.offsets and whole and not det[v].truncated[j]:
                b.offsets[v] = _measured(est, det[v].centroids[j], det[v].eye)
        if b.chroma is None:
            b.chroma = np.mean([det[v].chroma[j] for v, j in m.items()], axis=0)
        dt = t - b.t
        b.velocity = (est - b.position) / dt if (dt > 0 and not b.lost) else np.zeros(3)
        b.position, b.t = est, t
        b.lost, b.lost_frames, b.seen_views = False, 0, len(m)


def _predict(b: SmallBody, t: float, dT_ee: np.ndarray | None, push: np.ndarray | None) -> np.ndarray:
    """The body's hypotheses (h, 3): carried with the end effector (held); else where it was, at its last
    velocity, and moved by the tool's step ``push`` (a body in the tool's way)."""
    if b.held and dT_ee is not None:
        return (dT_ee[:3, :3] @ b.position + dT_ee[:3, 3])[None]
    out = [b.position]
    if not b.lost and np.any(b.velocity):
        out.append(b.position + b.velocity * max(t - b.t, 0.0))
    if push is not None:
        out.append(b.position + push)
    return np.array(out)


def _pushed(bodies: Sequence[SmallBody], tips: tuple[np.ndarray, np.ndarray], chain: float, on: bool) -> set[int]:
    """Indices of the bodies the tool may have moved since the last frame: those its tip swept within
    half their extent plus ``chain`` extents of, then, in turn, those within ``chain`` extents of a moved one:
    ahead of it along the tool's step (a pile pushes on), or on any side while the gripper or suction is on
    (a dragged rope follows)."""
    a, b = tips
    d = b - a
    n = float(np.linalg.norm(d))
    if n < 1e-3 or chain <= 0:
        return set()
    P = np.array([x.position for x in bodies])
    ext = np.array([x.extent for x in bodies])
    s = np.clip((P - a) @ d / (n * n), 0.0, 1.0)
    near = np.linalg.norm(P - (a + s[:, None] * d), axis=1) <= ext * (0.5 + chain)
    out = set(np.flatnonzero(near).tolist())
    todo = list(out)
    u = d / n
    while todo:
        k = todo.pop()
        rel = P - P[k]
        ahead = ((rel @ u > 0) | on) & (np.linalg.norm(rel, axis=1) <= chain * (ext + ext[k]) / 2 + ext[k])
        for j in np.flatnonzero(ahead).tolist():
            if j not in out:
                out.add(j)
                todo.append(j)
    return out
