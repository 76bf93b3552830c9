"""One body's frame in the depth tracker: its state, the guesses of its pose, and the search.

See :mod:`code_as_monitor.perception.trackers.depth` for the method. Poses are (4, 4) rigid transforms
from the body's model frame (the world at paint time) to the world now.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.geometry.transforms import rotation_about
from code_as_monitor.perception.trackers.base import DepthTrackerConfig
from code_as_monitor.perception.trackers.depth_body import RigidBody, Support, apply, invert, register, support
from code_as_monitor.perception.trackers.depth_views import Plane, ViewData, crop_scene

Owner = tuple[str, str]


@dataclass
class BodyState:
    """Tracking state of one rigid body (an object or a part)."""

    owner: Owner
    model: RigidBody | None
    parent: Owner | None = None
    T: np.ndarray = field(default_factory=lambda: np.eye(4))  # last good pose, model frame -> world
    T_prev: np.ndarray = field(default_factory=lambda: np.eye(4))  # the good pose before it
    T_search: np.ndarray = field(default_factory=lambda: np.eye(4))  # where a lost body is searched
    ref_seen: int = 1  # model points seen at paint time
    lost: bool = False
    lost_frames: int = 0
    lost_before: int = 0  # lost_frames before this frame's success (an overlap loss continues the count)
    moved: float = 0.0  # metres the last good step moved the model's centre
    held: bool = False  # within held_distance of the tip with the gripper on, last frame
    seen_views: int = 0
    last: Support | None = None  # evidence of the last good pose, in its frame
    painted: int = 0  # frame counter value when the model was painted (later = more recent evidence)
    rel: np.ndarray | None = None  # a part: its pose relative to its object's model frame (depth_claims)
    on_parent: bool = False  # a part placed where its object carries it this frame (its evidence is the object's)
    apart: bool = False  # its own pose stood against its object's carry the last time its object moved (depth_claims)
    small: bool = False  # too small to register on its own (depth_detect.is_small on the model): placed by its object
    free_s: float = math.inf  # seconds since the end-effector last carried it (inf: never)
    elements: list[int] = field(default_factory=list)


def pose_support(c: DepthTrackerConfig, model: RigidBody, T: np.ndarray, views: list[ViewData]) -> Support:
    """The views' evidence for ``model`` at pose ``T`` (4, 4): :func:`.depth_body.support` with the model's colours
    (a point seen at its depth in another object's colour is not seen; ``support_chroma``)."""
    return support(apply(T, model.points), views, c.depth_tol, c.max_depth, model.chroma, c.support_chroma,
                   c.chroma_min_sum)


def track_body(c: DepthTrackerConfig, body: BodyState, views: list[ViewData], plane: Plane | None,
               dT_ee: np.ndarray | None, related: list[np.ndarray], dt: float, tool: tuple | None,
               alone: bool = False, carried_first: bool = False) -> None:
    """One frame of one body: accept its unmoved (or object-carried) pose when the frame sees it as well
    as the last, else crop the scene around its guesses and search; update the body's state.

    Args:
        dT_ee: the end-effector's motion since the last frame (4, 4, world), when the body is held.
        related: this frame's motions (4, 4, world) of the other parts of its object, then of the object.
        dt: seconds since the last frame.
        tool: see :func:`.depth_views.crop_scene`.
        alone: a part whose object is lost this frame (and no other part of it moved it): a ``small`` body
            is then only accepted unmoved, never searched for (alone, its few points fit other surfaces).
        carried_first: a body with no parts of its own followed: held, it is carried first (see :func:`search`).
    """
    if body.model is None:
        return
    found: tuple[np.ndarray, Support] | None = None
    if views and not body.lost and dT_ee is None and body.last is not None:
        # At rest, or (a part) carried along rigidly by its object: no registration needed.
        carry = related[-1] if body.parent is not None and related and not body.apart else None
        found = _unmoved(c, body, views, carry)
    body.free_s = 0.0 if dT_ee is not None else body.free_s + dt
    settling = dT_ee is None and body.free_s <= SETTLE_S  # just let go: it may drop and lean where it lands
    guesses = _guesses(c, body, dT_ee, related, dt)
    if views and found is None and not (alone and body.small):
        boxes = [apply(T, body.model.box) for tier in guesses for T in tier]
        scene = crop_scene(views, boxes, c.margin_px, c.box_margin, c.max_depth,
                           None if body.model.in_plane else plane, c.plane_band, tool)
        if len(scene) >= c.min_points:
            found = search(c, body, views, scene, guesses, None if body.model.in_plane else plane,
                           climb=settling and not body.lost, held=dT_ee is not None, carried_first=carried_first)
    if found is None:
        body.lost = True
        body.lost_frames += 1
        body.seen_views = 0
        body.T_search = dT_ee @ body.T_search if dT_ee is not None else body.T_search
        return
    T, sup = found
    body.last = sup
    body.moved = float(np.linalg.norm(apply(T, body.model.centre[None]) - apply(body.T, body.model.centre[None])))
    body.T_prev, body.T, body.T_search = body.T, T, T
    body.lost, body.lost_before, body.lost_frames, body.seen_views = False, body.lost_frames, 0, sup.views

SETTLE_S = 1.0
"""Seconds after the end-effector last carried a body during which it is *settling*: it may drop and lean where it
lands, and when no registration passes, its projective evidence is climbed (:func:`search`, :func:`_climb_from`)."""


def _guesses(c: DepthTrackerConfig, body: BodyState, dT_ee: np.ndarray | None, related: list[np.ndarray],
             dt: float) -> list[list[np.ndarray]]:
    """Candidate poses in two tiers, most likely first. First: carried by the end-effector; moved like the
    parts of the same object already registered this frame (a drawer with its handle) and like the whole
    object; where it was; at constant velocity. Then, tried only when none of those fits (a fall is the
    less likely explanation; a fall guess that lands on an identical block must not win over a carried
    block's own pose): falling at constant acceleration; dropped from the gripper."""
    T0 = body.T_search if body.lost else body.T
    out: list[np.ndarray] = []
    falls: list[np.ndarray] = []
    if dT_ee is not None:
        out.append(dT_ee @ T0)
    for M in related:  # the motion as estimated, and its translation of this body's centre alone
        out.append(M @ T0)
        ctr = apply(T0, body.model.centre[None])[0] if body.model is not None else np.zeros(3)
        shifted = T0.copy()
        shifted[:3, 3] += apply(M, ctr[None])[0] - ctr
        out.append(shifted)
    out.append(T0)
    if not body.lost and body.moved > c.moving:
        step = body.T @ invert(body.T_prev)
        out.append(step @ T0)
        fall = step @ T0
        fall[2, 3] -= c.gravity * dt * dt
        falls.append(fall)
    if dT_ee is not None:  # released: a free-fall step below where the gripper took it
        drop = dT_ee @ T0
        drop[2, 3] -= 0.5 * c.gravity * dt * dt
        falls.append(drop)
    r = body.model.radius if body.model is not None else 0.05
    first = _distinct(out, r)
    return [first, [T for T in _distinct(first + falls, r) if not any(T is S for S in first)]]

def _unmoved(c: DepthTrackerConfig, body: BodyState, views: list[ViewData],
             parent_move: np.ndarray | None) -> tuple[np.ndarray, Support] | None:
    """The last pose (moved with the parent object when given), when the new frame sees the body there
    as well as the last frame saw it (no registration: most bodies are at rest most of the time, and a
    part mostly moves with its object)."""
    last = body.last
    assert body.model is not None and last is not None
    T = body.T.copy() if parent_move is None else parent_move @ body.T
    sup = pose_support(c, body.model, T, views)
    if (sup.seen >= c.unmoved_seen * last.seen
            and sup.contradicted <= last.contradicted + max(2, 0.02 * last.seen)
            and sup.residual <= last.residual + c.unmoved_residual):
        return T, last if parent_move is None else sup  # at rest the evidence stays the registration's
    return None

def search(c: DepthTrackerConfig, body: BodyState, views: list[ViewData], scene: np.ndarray,
           tiers: list[list[np.ndarray]], plane: Plane | None = None, climb: bool = False,
           held: bool = False, need: int | None = None,
           carried_first: bool = False) -> tuple[np.ndarray, Support] | None:
    """Register from each guess of a tier in order (most likely first), first with the finest
    correspondence distance only (a guess already close must not be pulled off by a neighbour's
    surface), then, when none passes, coarse to fine; the next tier (falls) only when nothing passed, from a
    coarser start (``fall_correspondence``) and with a higher bar (``fall_seen_frac``). With ``climb``, when no
    registration passes, or none that the frame contradicts no more than the last good pose (:func:`_rank`), the
    projective evidence is climbed from the best result and the likeliest guesses (:func:`_climb_from`; asked for
    a settling body only: for any body, a flat one gone from the table climbs into the table, whose surface then
    explains its points). The search stops at a passing result with as much evidence as the last frame had;
    otherwise the passing result that ranks first (:func:`_rank`: not more contradicted than the last pose, then
    the most evidence) wins (a static cabinet frame does not follow its drawer: the drawer's motion passes for it
    but fits worse than staying put). A ``held`` body (carried by the end-effector: its guesses are where the grip
    took it and where it would have slipped) is not taken further from a guess than the coarsest correspondence
    distance, once, rather than twice: a handle in closed jaws, registered from where it was before the pull's step,
    slid 3.3 cm along the drawer's front, where its model saw 144 points against the carry's 95.
    A pose that sinks the body more than ``plane_band`` into the support ``plane`` is refused: points behind a
    surface are only occluded to the cameras. ``need``: the fewest model points a result must see (default:
    ``min_seen``, and ``min_seen_frac`` of those seen at paint time).

    ``carried_first`` (with ``held``): a held body that carries no parts of its own (a block, a pen, a tap's lever;
    not a cabinet held by its handle, whose whole does not follow the grip) stays where the grip carried it (the
    first guess), unregistered, while that pose passes (``need`` seen, at most ``max_contradiction``) and the frame
    contradicts it no more than the last good pose. The hand that holds it hides most of it: a tap's lever turned
    from a view that looks down past the gripper showed 53-59 of its 390 points at every angle within 15 degrees,
    where registration turned it back 3-15 degrees a frame toward the closed lever and its pose trailed the grip by
    38 degrees at the end of the turn (a false "slipped out of the gripper"). A slip shows through the carried pose."""
    import small_gicp

    model = body.model
    assert model is not None
    source = small_gicp.voxelgrid_sampling(scene, model.voxel)
    if source.size() > 2 * c.max_model_points:  # a crop bigger than the body: a coarser grid
        coarser = model.voxel * np.sqrt(source.size() / (2 * c.max_model_points))
        source = small_gicp.voxelgrid_sampling(scene, coarser)
    if source.size() < max(16, c.min_points):  # too little to register (small_gicp warns at 10)
        return None
    if c.registration == "GICP":
        small_gicp.estimate_covariances(source, num_neighbors=10)
    need = max(c.min_seen, int(c.min_seen_frac * body.ref_seen)) if need is None else need
    fine = c.max_correspondence[-1:]
    guesses = [T for tier in tiers for T in tier]
    at_guess: list[Support | None] = [None] * len(guesses)
    best: tuple[np.ndarray, Support] | None = None
    coarse = c.max_correspondence if len(c.max_correspondence) > 1 else None
    passes = [(0, fine)] + ([(0, coarse)] if coarse else [])
    if len(tiers) > 1:  # a fall: far from every guess; it must explain the frame about as well as before
        passes.append((1, (c.fall_correspondence, *c.max_correspondence)))
    fall_need = max(need, int(c.fall_seen_frac * (body.last.seen if body.last is not None else body.ref_seen)))
    start = np.cumsum([0] + [len(t) for t in tiers])
    for tier, rounds in passes:
        if best is not None:
            break
        last = start[tier + 1] if rounds is fine or tier else min(start[tier + 1], start[tier] + 2)
        for i in range(start[tier], last):  # coarse rounds: from the two likeliest guesses only
            T0 = guesses[i]
            if held and carried_first and i == 0:  # carried by the grip: kept unless the frame sees through it
                at_guess[0] = g = pose_support(c, model, T0, views)
                if g.seen >= need and g.contradiction <= c.max_contradiction and _no_more_contradicted(body, g) \
                        and not _sinks(c, model, T0, plane):
                    return T0, g
            T, _ = register(model, source, T0, c.registration, rounds, c.max_iterations, c.min_information)
            sup = pose_support(c, model, T, views)
            if at_guess[i] is None:
                at_guess[i] = pose_support(c, model, T0, views)
            g = at_guess[i]
            assert g is not None
            # keep a guess the registration did not clearly improve, turned further than a body turns
            # between two frames, or carried further than twice its coarsest correspondence distance (it
            # walked onto another surface: a carried pen registered onto the robot's arm, 12 cm off) (the
            # configuration's coarsest distance, or a fall pass's; once for a held body)
            if (score(g) > score(sup) or _explains_as_well(c, g, sup) or _angle(T0, T) > c.max_rotation
                    or centre_shift(model, T0, T) > (1 if held else 2) * max(rounds[0], c.max_correspondence[0])):
                T, sup = T0, g
            if sup.seen < (need if tier == 0 else fall_need) or sup.contradiction > c.max_contradiction:
                continue
            if _sinks(c, model, T, plane):
                continue  # sunk into the support plane: the cameras cannot see that, but it is solid
            if best is None or _rank(body, sup) > _rank(body, best[1]):
                best = (T, sup)
            if _as_good_as_last(c, body, sup):
                return best
    if climb and (best is None or not _rank(body, best[1])[0]):
        starts = [T for T, g in zip(guesses[:start[1]], at_guess) if g is not None]
        climbed = _climb_from(c, body, views, starts if best is None else [best[0], *starts], need, plane)
        if climbed is not None and (best is None or _rank(body, climbed[1]) > _rank(body, best[1])):
            best = climbed
    return best


CLIMB_STEPS = 40
"""Most moves one climb of the projective evidence makes (:func:`_climb_from`)."""
CLIMB_FIRST_STEP = 4
"""Voxels of the climb's first shifts (then halved): a pen let go in its holder dropped 1.3 cm, and one-voxel steps
from where it was turned it 3 degrees in place, stuck with 35 of its points contradicted."""


def _climb_from(c: DepthTrackerConfig, body: BodyState, views: list[ViewData], starts: list[np.ndarray], need: int,
                plane: Plane | None) -> tuple[np.ndarray, Support] | None:
    """The pose that the views explain best (:func:`_rank`) near the two best of ``starts`` (4, 4), by coordinate
    ascent: shifts of :data:`CLIMB_FIRST_STEP` voxels along the world axes and turns of 2 degrees about them through
    the model's centre, halved when none improves, down to a quarter of a voxel, the centre kept within the coarsest
    correspondence distance of its start (a correction, not a search of the scene) and off poses that sink into
    ``plane`` (the coarse steps took a pen in its holder 1.5 cm too deep, where the holder hides it: refused, the
    pen was lost); accepted under the search's checks (``need`` seen points, at most ``max_contradiction``). The
    projection can tell where registration cannot: a thin pen let go into its holder, its model one side of it and
    three-quarters of its crop the holder, was turned 9-26 degrees by ICP from every guess while its true pose
    explained the frame with 87 points seen and 8 contradicted."""
    model = body.model
    assert model is not None

    def evidence(T: np.ndarray) -> Support:
        return pose_support(c, model, T, views)

    ranked = sorted(((T, evidence(T)) for T in starts), key=lambda x: _rank(body, x[1]), reverse=True)[:2]
    best: tuple[np.ndarray, Support] | None = None
    for T, sup in ranked:
        T_start, step, turn = T, CLIMB_FIRST_STEP * c.voxel, np.radians(2.0)
        for _ in range(CLIMB_STEPS):
            ctr = apply(T, model.centre[None])[0]
            moves = []
            for axis in np.eye(3):
                for sign in (-1.0, 1.0):
                    M = np.eye(4)
                    M[:3, 3] = sign * step * axis
                    moves.append(M)
                    R = rotation_about(axis, sign * turn)
                    M = np.eye(4)
                    M[:3, :3], M[:3, 3] = R, ctr - R @ ctr
                    moves.append(M)
            near = [M @ T for M in moves if centre_shift(model, T_start, M @ T) <= c.max_correspondence[0]
                    and not _sinks(c, model, M @ T, plane)]
            cand = max(((S, evidence(S)) for S in near), key=lambda x: _rank(body, x[1])) if near else (T, sup)
            if _rank(body, cand[1]) > _rank(body, sup):
                T, sup = cand
            elif step > c.voxel / 4:
                step, turn = step / 2, turn / 2
            else:
                break
        if sup.seen < need or sup.contradiction > c.max_contradiction:
            continue
        if _sinks(c, model, T, plane):
            continue
        if best is None or _rank(body, sup) > _rank(body, best[1]):
            best = (T, sup)
    return best


def _sinks(c: DepthTrackerConfig, model: RigidBody, T: np.ndarray, plane: Plane | None) -> bool:
    """Whether pose ``T`` (4, 4) puts ``model`` more than ``plane_band`` below the support ``plane``."""
    return plane is not None and float((apply(T, model.points) @ plane[0]).min()) + plane[1] < -c.plane_band


def _explains_as_well(c: DepthTrackerConfig, guess: Support, registered: Support) -> bool:
    """Whether a guessed pose's evidence is as good as the registered pose's: at least ``unmoved_seen`` of the points
    it sees in their own colour (:func:`matched`) and no more contradicted ones. The registration must then not move
    the body: a move the frame does not ask for is one along a direction it barely constrains (a block whose top the
    next block hides slides up its side faces, pulled toward the upper block's top, seeing one point more; or half
    onto a block of another colour that has just landed on it)."""
    return matched(guess) >= c.unmoved_seen * matched(registered) and guess.contradicted <= registered.contradicted


def _as_good_as_last(c: DepthTrackerConfig, body: BodyState, sup: Support) -> bool:
    """Whether ``sup`` is as much evidence as the body's last good pose had (the search may stop)."""
    last = body.last
    return last is not None and sup.seen >= c.unmoved_seen * last.seen and _no_more_contradicted(body, sup)


def _no_more_contradicted(body: BodyState, sup: Support) -> bool:
    """Whether the frame contradicts ``sup``'s pose no more than the body's last good pose (an allowance of 2
    points or 1 % of the last pose's seen ones); True without a last pose."""
    last = body.last
    return last is None or sup.contradicted <= last.contradicted + max(2, 0.01 * last.seen)


def moves_body(M: np.ndarray, body: BodyState) -> bool:
    """Whether the rigid motion ``M`` (4, 4) moves ``body``'s model centre by more than 1 mm."""
    if body.model is None:
        return False
    c = apply(body.T, body.model.centre[None])
    return bool(np.linalg.norm(apply(M, c) - c) > 1e-3)


def centre_shift(model: RigidBody, A: np.ndarray, B: np.ndarray) -> float:
    """Metres between the model's centre at poses ``A`` and ``B`` (4, 4)."""
    return float(np.linalg.norm(apply(B, model.centre[None]) - apply(A, model.centre[None])))


def _angle(A: np.ndarray, B: np.ndarray) -> float:
    """Degrees between the rotations of two poses (4, 4)."""
    R = A[:3, :3].T @ B[:3, :3]
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))


def _rank(body: BodyState, s: Support) -> tuple[bool, float]:
    """How a passing pose ranks in the search: first whether the frame contradicts it no more than it did the
    body's last good pose (:func:`_no_more_contradicted`), then its evidence (:func:`score`). Seen
    points cannot tell poses apart along a direction the body's shape does not constrain (a pen let go into its
    holder slides down its own axis: one centimetre higher its shaft is seen as well, and more of it, since less
    is hidden in the holder), while a contradicted point is the frame seeing through where the pose puts the body."""
    return _no_more_contradicted(body, s), score(s)


def matched(s: Support) -> int:
    """The points a pose sees at their depth and in their own colour (seen, less the recoloured ones)."""
    return s.seen - s.recoloured


def score(s: Support) -> float:
    """Evidence of a pose: points seen in their own colour (:func:`matched`), a contradicted point costing three."""
    return matched(s) - 3.0 * s.contradicted


def _distinct(poses: list[np.ndarray], radius: float) -> list[np.ndarray]:
    """``poses`` without near-duplicates (within 3 mm at the body's extent), first occurrence kept."""
    out: list[np.ndarray] = []
    for T in poses:
        if any(np.abs(T[:3, 3] - S[:3, 3]).max() < 0.003 and np.abs(T[:3, :3] - S[:3, :3]).max() * radius < 0.003
               for S in out):
            continue
        out.append(T)
    return out
