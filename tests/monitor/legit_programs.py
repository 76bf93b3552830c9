"""Legitimate monitor programs in the styles a VLM writes, with constructed states and the right verdicts.

Styles: helper functions, f-strings with format specs on numpy values, %-formatting, defensive guards no
perturbation reaches, history and velocities, margins, module-level constants, comprehensions, numpy
reductions that import lazily (median, percentile), array printing in reasons.

Each case: ``(name, constraints, source, start, checks)`` where ``start`` is the element state at subgoal
start (every ``during`` check holds there) and ``checks`` is a list of ``(state, expected ok per
constraint)``; a state is ``(E, H or None, H.t or None, t)``. World frame, metres, seconds.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.constraints import Constraint, Phase

D, U = Phase.DURING, Phase.UPON
SQUARE = np.array([[-0.02, -0.02, 0.0], [0.02, -0.02, 0.0], [0.02, 0.02, 0.0], [-0.02, 0.02, 0.0]])

ON_TABLE = SQUARE + np.array([0.3, 0.0, 0.02])
LOW = SQUARE + np.array([0.3, 0.0, 0.05])


def _carry(dz_tip: float = 0.0, block: np.ndarray | None = None, target_xy=(0.5, 0.2)) -> dict[int, np.ndarray]:
    """0: suction tip (point), 1: carried block top (surface, 2 cm under the tip), 2: target top (surface)."""
    tip = np.array([[0.3, 0.0, 0.25 + dz_tip]])
    top = SQUARE + np.array([0.3, 0.0, 0.23]) if block is None else block
    target = 1.25 * SQUARE + np.array([target_xy[0], target_xy[1], 0.05])
    return {0: tip, 1: top, 2: target}


def _tilted(deg: float) -> np.ndarray:
    a = np.radians(deg)
    R = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    return SQUARE @ R.T + [0.3, 0.0, 0.23]


def _history(E: dict[int, np.ndarray], moves: dict[int, np.ndarray], T: int = 5, dt: float = 0.1):
    """T frames ending at E; element i moved by moves[i] (m) over them."""
    w = np.linspace(1.0, 0.0, T)[:, None, None]
    H = {i: p[None] - w * moves.get(i, np.zeros(3))[None, None, :] for i, p in E.items()}
    return E, H, 1.0 - dt * np.arange(T)[::-1], 1.0


def _state(E: dict[int, np.ndarray]):
    return E, None, None, 1.0


ATTACHED_FSTRING = '''
def check_attached(E, H, t):
    gap = distance(E[0], E[1])
    if gap > 0.05:
        return False, f"block is {gap:.3f} m from the suction cup (limit 0.050)", 0.05 - gap
    return True, f"block attached, gap {gap:.3f} m", 0.05 - gap
'''

ATTACHED_PERCENT = '''
LIMIT = 0.05


def check_attached(E, H, t):
    gap = np.linalg.norm(E[0][0] - E[1].mean(axis=0))
    ok = gap <= LIMIT
    return bool(ok), "gap %.3f m (limit %.2f m)" % (gap, LIMIT), float(LIMIT - gap)
'''

LEVEL_GUARDED = '''
MAX_TILT_DEG = 15.0


def _tilt_deg(surface):
    n = normal(surface)
    return math.degrees(angle_to_vertical(n))


def check_level(E, H, t):
    top = E[1]
    if top.shape[0] < 3:
        return False, "block top has fewer than 3 points, cannot tell its tilt"
    tilt = _tilt_deg(top)
    return tilt < MAX_TILT_DEG, f"block top tilted {tilt:.1f} deg (max {MAX_TILT_DEG:.0f})", MAX_TILT_DEG - tilt
'''

ABOVE_TARGET = '''
def check_over_target(E, H, t):
    c = centroid(E[1])
    inside = point_in_polygon(c, E[2])
    h = signed_height(c, E[2])
    label = "above" if inside else "beside"
    return bool(inside and h > 0.0), f"block {label} the target, {h * 100:.1f} cm up"
'''

STILL_HISTORY = '''
def check_others_still(E, H, t):
    if len(H.t) < 2:
        return True, "no history yet", 0.02
    moved = displacement(H[2])
    return moved < 0.02, "target moved %.1f cm" % (moved * 100), 0.02 - moved
'''

SPEED_LIMIT = '''
MAX_SPEED = 0.5


def check_not_too_fast(E, H, t):
    ts = H.t
    if ts.shape[0] < 2:
        return True, "one frame only", MAX_SPEED
    c = np.array([centroid(H[1][k]) for k in range(ts.shape[0])])
    v = np.linalg.norm(np.diff(c, axis=0), axis=1) / np.maximum(np.diff(ts), 1e-6)
    vmax = float(np.max(v))
    return vmax <= MAX_SPEED, f"block speed up to {vmax:.2f} m/s (limit {MAX_SPEED} m/s)", MAX_SPEED - vmax
'''

TWO_CHECKS_SHARED_HELPER = '''
TOL = {"gap": 0.05, "tilt": math.radians(20)}


def measure(E):
    gap = distance(E[0], E[1])
    tilt = angle_between(normal(E[1]), np.array([0.0, 0.0, 1.0]))
    return gap, tilt


def check_attached(E, H, t):
    gap, _ = measure(E)
    return gap < TOL.get("gap", 0.05), f"gap={gap:.3f}", TOL["gap"] - gap


def check_level(E, H, t):
    _, tilt = measure(E)
    deg = np.degrees(tilt)
    return bool(tilt < TOL["tilt"]), f"tilt={deg:.1f}deg", float(TOL["tilt"] - tilt)
'''

STR_OF_ARRAYS = '''
def check_over_target(E, H, t):
    c = E[1].mean(axis=0)
    d = horizontal_distance(c, centroid(E[2]))
    where = np.round(c, 3)
    return d < 0.03, "block centre at %s, %.3f m from the target centre" % (where, d), 0.03 - d
'''

MEDIAN_ROBUST = '''
def check_lifted(E, H, t):
    z = np.median(E[1][:, 2])
    lo = np.percentile(E[1][:, 2], 10)
    return bool(lo > 0.1), f"block top at {z:.3f} m (10th percentile {lo:.3f})", float(lo - 0.1)
'''

ENUMERATE_CORNERS = '''
def check_level(E, H, t):
    zs = [p[2] for p in E[1].tolist()]
    mean_z = sum(zs) / len(zs)
    for i, z in enumerate(zs):
        if abs(z - mean_z) > 0.01:
            return False, f"corner {i} is {abs(z - mean_z) * 1000:.0f} mm off the mean height"
    return True, "all corners within 1 cm of the mean height"
'''

ISINSTANCE_GUARD = '''
def as_points(x):
    if not isinstance(x, np.ndarray):
        x = np.asarray(x, dtype=float)
    return x.reshape(-1, 3)


def check_attached(E, H, t):
    tip = as_points(E[0])
    top = as_points(E[1])
    gap = float(np.min(np.linalg.norm(top - tip, axis=1)))
    return gap < 0.06, "nearest corner " + str(round(gap, 3)) + " m from the tip", 0.06 - gap
'''

COMPREHENSION_ANY = '''
def check_others_still(E, H, t):
    T = len(H.t)
    jumps = [distance(H[2][k + 1], H[2][k]) for k in range(T - 1)]
    worst = max(jumps) if jumps else 0.0
    bad = any(j > 0.01 for j in jumps)
    return not bad, f"largest step of the target {worst * 1000:.1f} mm over {T} frames"
'''

ALLCLOSE_STYLE = '''
def check_others_still(E, H, t):
    first = H[2][0]
    same = np.allclose(first, E[2], atol=0.015)
    drift = float(np.abs(first - E[2]).max())
    return bool(same), "target drift %.4f m" % drift, 0.015 - drift
'''

NESTED_SPEC = '''
W = 6
P = 3


def check_attached(E, H, t):
    gap = distance(E[0], E[1])
    return gap < 0.05, f"gap [{gap:{W}.{P}f}] m", 0.05 - gap
'''

UNREACHED_NAN_GUARD = '''
def check_attached(E, H, t):
    gap = distance(E[0], E[1])
    if not np.isfinite(gap):
        return False, "tracking lost"
    if gap > 0.05:
        return False, f"dropped: gap {gap:.3f}"
    return True, f"held: gap {gap:.3f}"
'''

NUMPY_BOOL_RETURN = '''
def check_lifted(E, H, t):
    z = E[1][:, 2]
    return np.all(z > 0.1), f"lowest corner at {z.min():.3f} m", float(z.min() - 0.1)
'''

COUNT_INSIDE = '''
def check_over_target(E, H, t):
    n = count_in_polygon(E[1], E[2])
    return n >= 3, f"{n} of {len(E[1])} corners over the target"
'''

DOT_AND_CROSS = '''
UP = np.array([0.0, 0.0, 1.0])


def check_level(E, H, t):
    a = E[1][1] - E[1][0]
    b = E[1][3] - E[1][0]
    n = np.cross(a, b)
    n = n / max(np.linalg.norm(n), 1e-9)
    c = abs(np.dot(n, UP))
    ang = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
    return bool(ang < 12.0), "tilt %.1f deg" % ang, float(12.0 - ang)
'''

SORTED_AND_TERNARY = '''
def check_attached(E, H, t):
    d = sorted(float(np.linalg.norm(p - E[0][0])) for p in E[1])
    near = d[0]
    verdict = "holding" if near < 0.05 else "lost"
    return near < 0.05, f"{verdict}: nearest corner {near:.3f} m, farthest {d[-1]:.3f} m"
'''

ABOVE_WITH_MARGIN = '''
CLEARANCE = 0.01


def check_over_target(E, H, t):
    above = point_above_surface(centroid(E[1]), E[2], CLEARANCE)
    h = signed_height(centroid(E[1]), E[2])
    return above, ("over the target, " if above else "not over the target, ") + f"{h:+.3f} m"
'''

REPR_AND_FORMAT = '''
def check_attached(E, H, t):
    gap = distance(E[0], E[1])
    text = format(gap, ".4f")
    return gap < 0.05, "gap " + text + " m; tip " + repr(E[0][0].round(2).tolist())
'''

LEGIT: list[tuple] = [
    ("fstring_spec", [Constraint("attached", "block stays on the cup", D, element_ids=[0, 1])], ATTACHED_FSTRING,
     _carry(), [(_state(_carry()), [True]), (_state(_carry(dz_tip=0.2)), [False])]),
    ("percent_format", [Constraint("attached", "block stays on the cup", D, element_ids=[0, 1])], ATTACHED_PERCENT,
     _carry(), [(_state(_carry(dz_tip=0.01)), [True]), (_state(_carry(dz_tip=0.1)), [False])]),
    ("unreached_shape_guard", [Constraint("level", "block stays level", D, element_ids=[1])], LEVEL_GUARDED,
     _carry(), [(_state(_carry(block=_tilted(5))), [True]), (_state(_carry(block=_tilted(40))), [False])]),
    ("helpers_point_in_polygon", [Constraint("over_target", "block over the target", U, element_ids=[1, 2])],
     ABOVE_TARGET, _carry(), [(_state(_carry()), [False]), (_state(_carry(target_xy=(0.3, 0.0))), [True])]),
    ("history_displacement", [Constraint("others_still", "target does not move", D, element_ids=[2])],
     STILL_HISTORY, _carry(), [(_history(_carry(), {2: np.array([0.005, 0.0, 0.0])}), [True]),
                               (_history(_carry(), {2: np.array([0.1, 0.0, 0.0])}), [False])]),
    ("history_velocity", [Constraint("not_too_fast", "block moves slowly", D, element_ids=[1])], SPEED_LIMIT,
     _carry(), [(_history(_carry(), {1: np.array([0.05, 0.0, 0.0])}), [True]),
                (_history(_carry(), {1: np.array([0.6, 0.0, 0.0])}), [False])]),
    ("shared_helper_two_checks", [Constraint("attached", "on the cup", D, element_ids=[0, 1]),
                                  Constraint("level", "level", D, element_ids=[1])], TWO_CHECKS_SHARED_HELPER,
     _carry(), [(_state(_carry()), [True, True]), (_state(_carry(block=_tilted(35))), [True, False]),
                (_state(_carry(dz_tip=0.3)), [False, True])]),
    ("array_str_in_reason", [Constraint("over_target", "block centred over target", U, element_ids=[1, 2])],
     STR_OF_ARRAYS, _carry(), [(_state(_carry()), [False]), (_state(_carry(target_xy=(0.31, 0.0))), [True])]),
    ("median_percentile", [Constraint("lifted", "block lifted", U, element_ids=[1])], MEDIAN_ROBUST,
     _carry(block=ON_TABLE), [(_state(_carry()), [True]), (_state(_carry(block=LOW)), [False])]),
    ("enumerate_break", [Constraint("level", "block level", D, element_ids=[1])], ENUMERATE_CORNERS, _carry(),
     [(_state(_carry(block=_tilted(2))), [True]), (_state(_carry(block=_tilted(30))), [False])]),
    ("isinstance_guard", [Constraint("attached", "on the cup", D, element_ids=[0, 1])], ISINSTANCE_GUARD, _carry(),
     [(_state(_carry()), [True]), (_state(_carry(dz_tip=0.15)), [False])]),
    ("comprehension_any", [Constraint("others_still", "target still", D, element_ids=[2])], COMPREHENSION_ANY,
     _carry(), [(_history(_carry(), {2: np.array([0.0, 0.01, 0.0])}), [True]),
                (_history(_carry(), {2: np.array([0.0, 0.2, 0.0])}), [False])]),
    ("allclose", [Constraint("others_still", "target still", D, element_ids=[2])], ALLCLOSE_STYLE, _carry(),
     [(_history(_carry(), {2: np.array([0.01, 0.0, 0.0])}), [True]),
      (_history(_carry(), {2: np.array([0.0, 0.0, 0.05])}), [False])]),
    ("nested_format_spec", [Constraint("attached", "on the cup", D, element_ids=[0, 1])], NESTED_SPEC, _carry(),
     [(_state(_carry()), [True]), (_state(_carry(dz_tip=0.5)), [False])]),
    ("unreached_nan_guard", [Constraint("attached", "on the cup", D, element_ids=[0, 1])], UNREACHED_NAN_GUARD,
     _carry(), [(_state(_carry()), [True]), (_state(_carry(dz_tip=0.2)), [False])]),
    ("numpy_bool_result", [Constraint("lifted", "block lifted", U, element_ids=[1])], NUMPY_BOOL_RETURN,
     _carry(block=ON_TABLE), [(_state(_carry()), [True]), (_state(_carry(block=ON_TABLE)), [False])]),
    ("count_in_polygon", [Constraint("over_target", "block over target", U, element_ids=[1, 2])], COUNT_INSIDE,
     _carry(), [(_state(_carry()), [False]), (_state(_carry(target_xy=(0.3, 0.0))), [True])]),
    ("dot_cross_arccos", [Constraint("level", "level", D, element_ids=[1])], DOT_AND_CROSS, _carry(),
     [(_state(_carry(block=_tilted(8))), [True]), (_state(_carry(block=_tilted(25))), [False])]),
    ("sorted_ternary", [Constraint("attached", "on the cup", D, element_ids=[0, 1])], SORTED_AND_TERNARY,
     _carry(), [(_state(_carry()), [True]), (_state(_carry(dz_tip=0.3)), [False])]),
    ("above_with_margin", [Constraint("over_target", "block over target", U, element_ids=[1, 2])],
     ABOVE_WITH_MARGIN, _carry(), [(_state(_carry()), [False]), (_state(_carry(target_xy=(0.3, 0.0))), [True])]),
    ("repr_and_format", [Constraint("attached", "on the cup", D, element_ids=[0, 1])], REPR_AND_FORMAT, _carry(),
     [(_state(_carry()), [True]), (_state(_carry(dz_tip=0.2)), [False])]),
]
"""The legitimate programs; ``unreached_*`` ones contain a guard that no perturbation reaches."""
