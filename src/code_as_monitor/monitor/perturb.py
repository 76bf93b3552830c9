"""Perturbations of an element state, used to drive every branch of a monitor program at subgoal start.

Each perturbation is a plausible-but-different world: elements translated by a few centimetres or up
to ~0.3 m, raised or lowered, lines and surfaces rotated, elements moved apart or together, points
piled on one another (degenerate lines and surfaces), elements swapped, histories that are
static, moving, turning (a line or surface that rotated into its current pose), short (T = 1, 2) or
longer, meetings (one element moved since the oldest frame to where another is now: a block carried
up to the suction tip), departures (one element moved away since the oldest frame while the others stayed:
a block knocked off the gripper's path) and placements (one element put just above another: a block over
its target; pairs that one constraint names together at several heights) and, last, turns about the vertical at
stratified angles (a lever or a lid turned on the table by so much). Elements of one object part
(``groups``: several point elements when lines and surfaces are handed over as unconnected points) move together
in the meetings, departures and placements and turn together in turning histories, as the part they stand for would.
Every array is world frame, metres; times are seconds.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

State = tuple[dict[int, np.ndarray], dict[int, np.ndarray], np.ndarray]
"""(elements id -> (k, 3), history id -> (T, k, 3), history times (T,))."""


@dataclass
class Probe:
    """One input for path coverage: a description (for the coder) and the state to evaluate."""

    description: str
    elements: dict[int, np.ndarray]
    history: dict[int, np.ndarray]
    history_t: np.ndarray


def _fmt(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:+.2f}" for x in v) + "]"


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / max(np.linalg.norm(axis), 1e-12)
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def normalise_state(elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
                    history_t: np.ndarray | None, t: float) -> State:
    """Float64 copies; a missing history (or element) becomes the current frame alone (T = 1)."""
    E = {int(i): np.array(p, dtype=np.float64).reshape(-1, 3) for i, p in elements.items()}
    if not history:
        return E, {i: p[None].copy() for i, p in E.items()}, np.array([t], dtype=np.float64)
    H = {int(i): np.array(h, dtype=np.float64) for i, h in history.items()}
    T = next(iter(H.values())).shape[0]
    Ht = np.array(history_t, dtype=np.float64) if history_t is not None else t - _dt(None) * np.arange(T)[::-1]
    for i, p in E.items():
        if i not in H:
            H[i] = np.repeat(p[None], T, axis=0)
    return E, H, Ht


def _dt(history_t: np.ndarray | None) -> float:
    if history_t is None or len(history_t) < 2:
        return 1.0 / 30.0
    d = float(np.median(np.diff(history_t)))
    return d if d > 0 else 1.0 / 30.0


def _times(T: int, t: float, dt: float) -> np.ndarray:
    return t - dt * np.arange(T, dtype=np.float64)[::-1]


def _map_elements(state: State, fns: dict[int, Callable[[np.ndarray], np.ndarray]]) -> State:
    """Apply a per-element point map to the current points and to every history frame."""
    E, H, Ht = state
    E2 = {i: (fns[i](p) if i in fns else p.copy()) for i, p in E.items()}
    H2 = {i: (np.stack([fns[i](f) for f in h]) if i in fns else h.copy()) for i, h in H.items()}
    return E2, H2, Ht.copy()


def _with_history(state: State, T: int, t: float, start_offset: np.ndarray | None) -> State:
    """Replace the history by T frames ending at the current points: static, or moving from an offset."""
    E, _, Ht = state
    dt = _dt(Ht)
    H = {}
    for i, p in E.items():
        if start_offset is None or T == 1:
            H[i] = np.repeat(p[None], T, axis=0)
        else:
            w = np.linspace(1.0, 0.0, T)[:, None, None]
            H[i] = p[None] + w * start_offset[None, None, :]
    return {i: p.copy() for i, p in E.items()}, H, _times(T, t, dt)


TURNS_PER_ELEMENT = 3
"""Turning-history probes per line or surface element, added after the ``n`` perturbations: a check that
compares an element's direction with its oldest one (a book turned under the gripper) needs them."""
YAW_TURNS = 6
"""Turning-history probes about the vertical per line or surface element (or part), added last: a lever, knob, lid
or book turned on the table turns about the vertical, and a check that asks for a turn within a band of angles
(a tap turned 60 degrees, judged 45 to 75) is only True there, which the random-axis turns above, whose turn seen
from above is smaller, rarely reach. Angles drawn from as many equal strata of 0.2 rad to a quarter-turn (strata
13 degrees wide: every band at least 26 degrees wide holds one whole stratum)."""
MAX_MEETINGS = 30
"""Meeting probes (element b raised, and element a moved since the oldest frame to where b is then) added
after the turning histories: a check that an object rose with the gripper since the grasp began (a block
carried up by the suction tip) needs them, also when the gripper starts at the object (a re-grasp). All
ordered pairs up to this many, else a seeded sample of pairs."""

DEPARTURES_PER_ELEMENT = 2
"""Departure probes per element (or part) added after the meetings: the element moved away since the oldest frame
(knocked or slid 4-30 cm off where it is now) while the others stayed. A check that an object stays put unless the
gripper holds it is False only when the object both moved and is away from the gripper; when a subgoal starts with
the gripper at the object (a re-grasp), no other probe moves one element's current point and its history apart."""

MAX_PLACEMENTS = 30
"""Placement probes (element i put just above element j) added after the meetings, last: a check that a
block ends up over its target is only True near that configuration, which random translations of a few
decimetres rarely reach. All ordered pairs up to this many, else a seeded sample of pairs; pairs a constraint names
together (``related``) come first."""

PLACEMENT_HEIGHTS = 3
"""Placements per ordered pair of elements that one constraint names together, at heights drawn from as many equal
strata of the 1-6 cm range: one draw per pair can miss a check's own height band (a block's centre 2-6 cm above the
one below), and a check then read "can never be satisfied" is rejected, although it only says the world is far from
it (a tower that already fell). Other pairs get one placement each."""
PLACEMENT_LIFT = (0.01, 0.06)
"""Range of a placement's gap (m) between the top of the element below and the bottom of the one put above."""


def make_probes(elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
                history_t: np.ndarray | None, t: float, n: int, seed: int = 0,
                groups: dict[int, list[int]] | None = None,
                related: list[list[int]] | None = None) -> list[Probe]:
    """The unperturbed state first, then ``n`` perturbations cycling through the families above, then the
    turning histories (:data:`TURNS_PER_ELEMENT`), the meetings (:data:`MAX_MEETINGS`), the departures
    (:data:`DEPARTURES_PER_ELEMENT` per element or part) and the placements
    (:data:`MAX_PLACEMENTS`). ``groups``: element id -> the ids of its object part (itself included; None or a
    missing id: the element alone); a meeting or placement moves an element's whole group rigidly, except
    between two elements of one group. ``related``: the element ids of each constraint; ordered pairs within one
    get :data:`PLACEMENT_HEIGHTS` placements each, before the other pairs."""
    base = normalise_state(elements, history, history_t, t)
    probes = [Probe("the current state (unperturbed)", *base)]
    ids = sorted(base[0])
    if not ids:
        return probes
    rng = np.random.default_rng(seed)
    T0 = next(iter(base[1].values())).shape[0]
    centre = np.mean([p.mean(axis=0) for p in base[0].values()], axis=0)

    def translate_all(scale: float) -> Probe:
        offs = {i: rng.uniform(-scale, scale, 3) for i in ids}
        desc = ", ".join(f"{i}: {_fmt(o)}" for i, o in offs.items())
        return Probe(f"every element translated (m) {desc}",
                     *_map_elements(base, {i: (lambda p, o=o: p + o) for i, o in offs.items()}))

    def translate_one(axis_z: bool) -> Probe:
        i = ids[int(rng.integers(len(ids)))]
        o = np.zeros(3)
        if axis_z:
            o[2] = rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.3)
        else:
            o = rng.uniform(-0.3, 0.3, 3)
        return Probe(f"element {i} translated by {_fmt(o)} m", *_map_elements(base, {i: lambda p: p + o}))

    def rotate() -> Probe:
        i = ids[int(rng.integers(len(ids)))]
        axis = rng.normal(size=3)
        angle = rng.uniform(0.2, np.pi / 2) * rng.choice([-1.0, 1.0])
        R = _rotation(axis, angle)
        c = base[0][i].mean(axis=0)
        return Probe(f"element {i} rotated by {np.degrees(angle):.0f} deg about its centroid, axis {_fmt(axis)}",
                     *_map_elements(base, {i: lambda p: (p - c) @ R.T + c}))

    def scale_about_centre(s: float) -> Probe:
        word = "apart" if s > 1 else "together"
        shifts = {i: (p0.mean(axis=0) - centre) * (s - 1.0) for i, p0 in base[0].items()}
        fns = {i: (lambda p, d=d: p + d) for i, d in shifts.items()}
        return Probe(f"elements moved {word} (centroid distances to the scene centre x{s:.2f})",
                     *_map_elements(base, fns))

    def pile(all_elements: bool) -> Probe:
        if all_elements:
            fns = {i: (lambda p: np.repeat(centre[None], len(p), axis=0)) for i in ids}
            return Probe(f"every point of every element piled at {_fmt(centre)}", *_map_elements(base, fns))
        fns = {i: (lambda p: np.repeat(p.mean(axis=0, keepdims=True), len(p), axis=0)) for i in ids}
        return Probe("each element's points piled on its centroid (degenerate lines and surfaces)",
                     *_map_elements(base, fns))

    def swap() -> Probe:
        if len(ids) < 2:
            return translate_one(False)
        a, b = rng.choice(ids, 2, replace=False)
        d = base[0][b].mean(axis=0) - base[0][a].mean(axis=0)
        return Probe(f"elements {a} and {b} swapped places",
                     *_map_elements(base, {int(a): lambda p: p + d, int(b): lambda p: p - d}))

    def history_variant() -> Probe:
        T = int(rng.choice([1, 2, 3, max(T0, 2), 2 * max(T0, 5)]))
        if rng.random() < 0.4:
            return Probe(f"static history of T={T} frames", *_with_history(base, T, t, None))
        o = rng.uniform(-0.3, 0.3, 3)
        return Probe(f"history of T={T} frames moving by {_fmt(-o)} m to the current points",
                     *_with_history(base, T, t, o))

    turn_rng = np.random.default_rng([seed, 1])  # its own stream: the other probes stay as they were

    def turning_history(i: int, members: list[int] | None = None, axis: np.ndarray | None = None,
                        angle: float | None = None, rng: np.random.Generator = turn_rng) -> Probe:
        g = members or [i]
        axis = rng.normal(size=3) if axis is None else axis
        angle = rng.uniform(0.2, np.pi / 2) * rng.choice([-1.0, 1.0]) if angle is None else angle
        T = int(rng.choice([2, 3, max(T0, 5)]))
        E, H, Ht = _with_history(base, T, t, None)
        c = np.concatenate([E[k] for k in g], axis=0).mean(axis=0)
        for k in g:
            H[k] = np.stack([(E[k] - c) @ _rotation(axis, angle * w).T + c for w in np.linspace(1.0, 0.0, T)])
        what = f"element {i}" if len(g) == 1 else f"elements {', '.join(map(str, g))} (one part)"
        return Probe(f"history of T={T} frames in which {what} turned {np.degrees(angle):.0f} deg (axis "
                     f"{_fmt(axis)}) into its current pose", E, H, Ht)

    families: list[Callable[[], Probe]] = [
        lambda: translate_all(0.03), lambda: translate_one(False), lambda: translate_one(True),
        lambda: translate_all(0.3), rotate, history_variant, lambda: scale_about_centre(rng.uniform(1.5, 4.0)),
        lambda: scale_about_centre(rng.uniform(0.0, 0.5)), swap, lambda: translate_all(0.1),
    ]
    fixed = [lambda: pile(False), lambda: pile(True),
             lambda: Probe("history of T=1 frame (just the current points)", *_with_history(base, 1, t, None)),
             lambda: scale_about_centre(0.0)]
    for k in range(n):
        make = fixed[k] if k < len(fixed) else families[(k - len(fixed)) % len(families)]
        probes.append(make())
    for i in (i for i in ids if len(base[0][i]) >= 2):  # lines and surfaces: a few turning histories each
        probes += [turning_history(i) for _ in range(TURNS_PER_ELEMENT)]
    parts = sorted({tuple(g) for g in (groups or {}).values() if len([k for k in g if k in base[0]]) >= 2})
    for g in parts:  # several elements of one part (its points, with CP off): the part turns as one
        members = [k for k in g if k in base[0]]
        probes += [turning_history(members[0], members) for _ in range(TURNS_PER_ELEMENT)]
    meet_rng = np.random.default_rng([seed, 2])  # its own stream too

    def group_pair(a: int, b: int) -> tuple[list[int], list[int]]:
        ga = [i for i in (groups or {}).get(a, [a]) if i in base[0]] or [a]
        gb = [i for i in (groups or {}).get(b, [b]) if i in base[0]] or [b]
        return ([a], [b]) if b in ga else (ga, gb)

    def meeting(a: int, b: int) -> Probe:
        E0, H0, Ht0 = base
        ga, gb = group_pair(a, b)
        dz = float(meet_rng.uniform(-0.02, 0.02))
        lift = float(meet_rng.uniform(0.06, 0.15))  # b rose: a carried up, even from where b started
        E = {i: p.copy() for i, p in E0.items()}
        for i in gb:
            E[i] = E[i] + np.array([0.0, 0.0, lift])
        o = _points_of(E, gb).mean(axis=0) - _points_of(E, ga).mean(axis=0) + np.array([0.0, 0.0, dz])
        for i in ga:
            E[i] = E[i] + o
        H = {i: np.concatenate([h, E[i][None]]) for i, h in H0.items()}  # one frame more: the move
        Ht = np.concatenate([Ht0 - _dt(Ht0), [t]])
        return Probe(f"element {b} raised {lift:.2f} m and element {a} moved since the oldest frame to it "
                     f"({dz:+.2f} m above its centre)", E, H, Ht)

    pairs = [(a, b) for a in ids for b in ids if a != b]
    if len(pairs) > MAX_MEETINGS:
        pairs = [pairs[k] for k in sorted(meet_rng.choice(len(pairs), MAX_MEETINGS, replace=False))]
    probes += [meeting(a, b) for a, b in pairs]
    leave_rng = np.random.default_rng([seed, 4])  # its own stream: the probes before stay as they were

    def departure(g: list[int]) -> Probe:
        E0, H0, Ht0 = base
        d = leave_rng.normal(size=3)
        d[2] *= 0.3  # mostly sideways, as a knocked or sliding object moves
        o = d / max(float(np.linalg.norm(d)), 1e-12) * float(leave_rng.uniform(0.04, 0.3))
        E = {i: (p + o if i in g else p.copy()) for i, p in E0.items()}
        H = {i: np.concatenate([h, E[i][None]]) for i, h in H0.items()}  # one frame more: the move
        Ht = np.concatenate([Ht0 - _dt(Ht0), [t]])
        what = f"element {g[0]}" if len(g) == 1 else f"elements {', '.join(map(str, g))} (one part)"
        return Probe(f"{what} moved away by {_fmt(o)} m since the oldest frame, the others stayed", E, H, Ht)

    movers = sorted({tuple(sorted(k for k in (groups or {}).get(i, [i]) if k in base[0]) or [i]) for i in ids})
    probes += [departure(list(g)) for g in movers for _ in range(DEPARTURES_PER_ELEMENT)]
    place_rng = np.random.default_rng([seed, 3])  # a stream of its own
    probes += [_placement(base, i, j, group_pair(i, j), lift)
               for i, j, lift in _placement_plan(ids, related, groups, place_rng)]
    yaw_rng = np.random.default_rng([seed, 4])  # a stream of its own, last: the probes above stay as they were
    up = np.array([0.0, 0.0, 1.0])
    turners = [(i, None) for i in ids if len(base[0][i]) >= 2]
    turners += [(m[0], m) for m in ([k for k in g if k in base[0]] for g in parts)]
    for i, members in turners:
        for lo, hi in itertools.pairwise(np.linspace(0.2, np.pi / 2, YAW_TURNS + 1)):
            angle = float(yaw_rng.uniform(lo, hi)) * float(yaw_rng.choice([-1.0, 1.0]))
            probes.append(turning_history(i, members, up, angle, yaw_rng))
    return probes


def _points_of(E: dict[int, np.ndarray], g: list[int]) -> np.ndarray:
    """The points (n, 3) of the elements ``g`` of state ``E``, stacked."""
    return np.concatenate([E[i] for i in g], axis=0)


def _related_pairs(ids: list[int], related: list[list[int]] | None,
                   groups: dict[int, list[int]] | None) -> set[tuple[int, int]]:
    """Ordered pairs of present elements that one constraint names together (not two points of one part)."""
    present = set(ids)
    out: set[tuple[int, int]] = set()
    for members in related or []:
        m = [int(k) for k in members if int(k) in present]
        out |= {(a, b) for a in m for b in m if a != b and b not in (groups or {}).get(a, [a])}
    return out


def _placement_plan(ids: list[int], related: list[list[int]] | None, groups: dict[int, list[int]] | None,
                    rng: np.random.Generator) -> list[tuple[int, int, float]]:
    """(element put above, element below, gap in m) of every placement probe: at most :data:`MAX_PLACEMENTS` pairs,
    those a constraint names together first with :data:`PLACEMENT_HEIGHTS` stratified gaps each, then a seeded
    sample of the others with one gap each."""
    close = _related_pairs(ids, related, groups)
    first = [(i, j) for i in ids for j in ids if (i, j) in close]
    rest = [(i, j) for i in ids for j in ids if i != j and (i, j) not in close]
    if len(first) > MAX_PLACEMENTS:
        first = [first[k] for k in sorted(rng.choice(len(first), MAX_PLACEMENTS, replace=False))]
    room = MAX_PLACEMENTS - len(first)
    if len(rest) > room:
        rest = [rest[k] for k in sorted(rng.choice(len(rest), room, replace=False))] if room > 0 else []
    lo, hi = PLACEMENT_LIFT
    edges = np.linspace(lo, hi, PLACEMENT_HEIGHTS + 1)
    plan = [(i, j, float(rng.uniform(a, b))) for i, j in first for a, b in itertools.pairwise(edges)]
    return plan + [(i, j, float(rng.uniform(lo, hi))) for i, j in rest]


def _placement(base: State, i: int, j: int, pair: tuple[list[int], list[int]], lift: float) -> Probe:
    """Element ``i`` (with its group ``pair[0]``) moved rigidly so that its lowest point is ``lift`` above the
    highest point of ``j`` (its group ``pair[1]``), centred on it horizontally."""
    gi, gj = pair
    Pi, Pj = _points_of(base[0], gi), _points_of(base[0], gj)
    o = Pj.mean(axis=0) - Pi.mean(axis=0)
    o[2] = Pj[:, 2].max() + lift - Pi[:, 2].min()
    return Probe(f"element {i} placed {lift * 100:.0f} cm above element {j} (moved by {_fmt(o)} m)",
                 *_map_elements(base, {k: lambda p, o=o: p + o for k in gi}))
