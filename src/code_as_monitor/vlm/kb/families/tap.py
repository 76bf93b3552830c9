# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``tap`` (task ``turn-tap``): turn the left (or right) tap's handle open.

Plan: ``grasp`` the named handle's lever (jaws across the bar) -> ``turn`` it ``TURN_DEG`` about its hinge (the
skill turns it outwards and lets go at the end) -> done.

How far: a quarter-turn (``TURN_DEG``), or an angle the instruction gives ("turn the left tap 45 degrees", "by 60
degrees"), from ``MIN_TURN_DEG`` to ``TURN_DEG``: the task's ``angle`` (its success is within ``TURN_TOL_DEG`` of
it) and the checks' band. Bounds ("at least 45 degrees", "up to 60 degrees") are refused: the turn aims at one angle.

Elements: the grasp point (``robot/tip``, point), the named handle's lever (``tap/left_handle``, a LINE: the
lever's two ends; its direction is what turns), the other handle (``tap/right_handle``, point), the jaws
(``robot/finger_left``, ``robot/finger_right``: proprioception). A handle is judged by its own elements, so
grasping the other handle (the two look alike but for their colour) fails the grasp's checks on the named one.

Recovery by the failed constraint's id prefix: ``leverstill``, ``levergrip``, ``jawshut`` (not held, or the
wrong handle held), ``levered``, ``turned`` (not turned far enough), ``otherstill`` (the other handle was moved;
the kb cannot turn it back) -> grasp the named handle again, then turn it; ``leverfreed`` (still held) -> turn again
(it ends by letting go).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name
from code_as_monitor.vlm.kb.shared.feedback import failed_kind
from code_as_monitor.vlm.kb.shared.grip import FINGER_LEFT, FINGER_RIGHT, GRIP_TIP, freed, part_spec
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

TURN_DEG = 90.0
"""Degrees a tap's handle turns from closed to open (a quarter-turn), and the most the kb turns it."""
MIN_TURN_DEG = 30.0
"""The least turn the kb plans: below it the tolerance band reaches the closed lever."""
TURN_TOL_DEG = 15.0
"""Degrees either side of the angle asked for that count as turned so (75 of 90: a lever a quarter-turn open, give
or take the painted line's direction error). The lever's travel (100 degrees, sim/assets/tap.urdf) ends inside the
band above a quarter-turn, so only a smaller turn has an upper bound to check."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # From sim/assets/tap.urdf: a lever is a 7 cm bar, 1.4 cm thick, on a hinge; the handles are 16 cm apart.
    # grasp, during (proactive): the named lever stays where it is (within 2 cm) until it is gripped: a lever
    # turned 2 cm at its middle is out of the closing jaws.
    "leverstill": {"max_disp": 0.02},
    # grasp, upon: the lever's middle within 3 cm of the grasp point (its painted middle from the bar's
    # visible pixels beside the fingers); the other handle's lever is 16 cm away.
    "levergrip": {"max_dist": 0.03},
    # grasp, upon: the jaws closed on a 1.4 cm bar: 1 to 5 cm apart (as on the drawer's handle).
    "lever_jaw": {"min_jaw": 0.01, "max_jaw": 0.05},
    # turn, during: the lever stays in the gripper (within 3 cm) until it has turned most of the way.
    "levered": {"max_dist": 0.03, "min_turn": 1.31},
    # turn, during: the other handle does not move (2 cm).
    "otherstill": {"max_disp": 0.02},
    # turn, upon: the lever's direction turned at least 75 degrees (1.31 rad) of the 90 since the turn began:
    # a lever a quarter-turn open, give or take the painted line's direction error (TURN_TOL_DEG). For a smaller
    # turn asked for, the band is the angle -+ TURN_TOL_DEG (``max_turn`` then added).
    "turned": {"min_turn": 1.31},
    # turn, upon: released: the grasp point 6 cm from the lever's middle (3 cm grip tolerance + the fingers'
    # 3 cm reach past the bar).
    "lever_freed": {"release_dist": 0.06},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


@dataclass(frozen=True)
class TapGoal:
    """The tap, the handle to turn, the other one, and how far to turn it (degrees)."""

    tap: str
    part: str
    other: str
    angle: float = TURN_DEG

    @property
    def quarter_turn(self) -> bool:
        """Whether the turn is the default quarter-turn (no angle asked for: no upper bound, no task parameter)."""
        return abs(self.angle - TURN_DEG) < 1e-9


VERBS = ("turn", "open", "grasp")
MODIFIERS = ("open", "on", "fully")
HEADS = ("tap", "handle")
DOING = (f"turns the named tap's handle a quarter-turn open, or an angle from {MIN_TURN_DEG:g} to {TURN_DEG:g} "
         f"degrees")


def claims(ins: Instruction) -> bool:
    return "tap" in ins.heads


def understand(ins: Instruction, objects: list[str]) -> TapGoal | None:
    """The tap and the handle (left or right) grounded on ``objects``; None when not about a tap."""
    if not claims(ins):
        return None
    r = Reading(ins, "turn-tap", heads=HEADS, verbs=VERBS)
    r.verbs(VERBS, DOING)
    r.modifiers(MODIFIERS, DOING)
    if not {"turn", "open"} & set(ins.verbs):
        r.refuse("say what to do with the tap: turn it")
    sides = set()
    for p in r.phrases(lambda p: p.head in HEADS):
        q = ins.resolve(p.index)
        if q.position in ("left", "right"):
            sides.add(q.position)
        elif q.position or q.ordinal:
            r.refuse(f"{p.text!r}: say which tap, the left or the right one")
        qty = q.quantity  # "both taps", "half of the left tap"; before, with a side it went unread
        if qty is not None and not (qty.kind == "number" and qty.value == 1 and qty.of_total in (None, 1)):
            r.refuse(f"{qty.text!r}: say which tap, the left or the right one (one handle is turned)")
        if q.colour:
            r.refuse(f"{p.text!r}: name the tap by its side (left or right), not its colour")
        r.use(p.index)
    for k in ins.links:
        if k.kind == "of" and ins.resolve(k.b).head == "tap":
            r.use_link(k)
        elif k.kind == "on" and k.a is None and k.words == "on" and ins.resolve(k.b).head == "tap" \
                and "turn" in ins.verbs:
            r.use_link(k)  # "turn on the tap (on the right)": the particle "on" before the object, as "turn it on"
    if len(sides) != 1:
        r.refuse("say which tap to turn: the left or the right one")
    tap = next((o for o in scene_names(objects) if "tap" in o or "faucet" in o), "")
    if not tap:
        r.refuse("the scene has no tap")
    side = sides.pop()
    angle = _angle(r)
    r.finish()
    return TapGoal(tap, f"{side}_handle", f"{'right' if side == 'left' else 'left'}_handle", angle)


def _angle(r: Reading) -> float:
    """Degrees to turn: the instruction's angle, or a quarter-turn (the measures read are marked used)."""
    angles = [(i, m) for i, m in enumerate(r.ins.measures) if m.kind == "angle"]
    if not angles:
        return TURN_DEG
    if len(angles) > 1:
        r.refuse("say one angle, e.g. 'turn the left tap 45 degrees'")
    i, m = angles[0]
    r.used_measures.add(i)
    if m.bound not in ("plain", "about", "exact"):
        r.refuse(f"cannot promise {m.text!r}: the turn aims at one angle, judged within {TURN_TOL_DEG:g} degrees "
                 f"of it (say e.g. 'turn the left tap 45 degrees')")
    if not MIN_TURN_DEG - 1e-9 <= m.value <= TURN_DEG + 1e-9:
        r.refuse(f"cannot turn the tap {m.text!r}: the kb turns a handle {MIN_TURN_DEG:g} to {TURN_DEG:g} degrees "
                 f"(a quarter-turn opens it)")
    return round(float(m.value), 2)


def scene(ins: Instruction) -> list[str] | None:
    """The turn-tap scene's objects, or None."""
    return ["tap", "table"] if claims(ins) else None


# --- constraint builders -----------------------------------------------------------------------------------
def _lever(g: TapGoal) -> dict[str, str]:
    return part_spec(g.tap, g.part, "line", f"{g.part.split('_')[0]} lever")


def _other(g: TapGoal) -> dict[str, str]:
    return part_spec(g.tap, g.other, "point", f"{g.other.split('_')[0]} handle")


def grasp(g: TapGoal) -> list[dict[str, Any]]:
    """``grasp`` the named lever: during (proactive) it stays put; upon, it is at the grasp point, jaws closed."""
    st, gr, jw = _thr("leverstill"), _thr("levergrip"), _thr("lever_jaw")
    name = f"the {g.part.replace('_', ' ')} of {nice(g.tap)}"
    return [
        constraint(f"leverstill_{g.tap}", f"{name} stays where it is (within {st['max_disp'] * 100:.0f} cm) while the "
                   f"gripper approaches and closes", "during", True, st, [_lever(g)]),
        constraint(f"levergrip_{g.tap}", f"{name} is between the fingers: its lever's middle within "
                   f"{gr['max_dist'] * 100:.0f} cm of the grasp point", "upon", False, gr, [GRIP_TIP, _lever(g)]),
        constraint(f"jawshut_{g.tap}", f"the gripper's jaws are closed on {name}: their opening between "
                   f"{jw['min_jaw'] * 100:.0f} and {jw['max_jaw'] * 100:.0f} cm", "upon", False, jw,
                   [FINGER_LEFT, FINGER_RIGHT]),
    ]


def turn(g: TapGoal) -> list[dict[str, Any]]:
    """``turn``: during, the lever stays in the gripper and the other handle stays put; upon, the lever turned
    the angle asked for (most of a quarter-turn by default) and is released."""
    lv, ot, tu, fr = _thr("levered"), _thr("otherstill"), _thr("turned"), _thr("lever_freed")
    least = g.angle - TURN_TOL_DEG
    if not g.quarter_turn:
        lv["min_turn"] = tu["min_turn"] = round(math.radians(least), 4)
        tu["max_turn"] = round(math.radians(g.angle + TURN_TOL_DEG), 4)
    band = f"at least {least:.0f} degrees" if "max_turn" not in tu else \
        f"{least:.0f} to {g.angle + TURN_TOL_DEG:.0f} degrees (asked: {g.angle:g})"
    name = f"the {g.part.replace('_', ' ')} of {nice(g.tap)}"
    return [
        constraint(f"levered_{g.tap}", f"{name} stays in the gripper (within {lv['max_dist'] * 100:.0f} cm of the grasp "
                   f"point) until it has turned {least:.0f} degrees", "during", False, lv, [GRIP_TIP, _lever(g)]),
        constraint(f"otherstill_{g.tap}", f"the {g.other.replace('_', ' ')} of {nice(g.tap)} does not move (within "
                   f"{ot['max_disp'] * 100:.0f} cm)", "during", False, ot, [_other(g)]),
        constraint(f"turned_{g.tap}", f"{name} turned {band} since the turn began (its lever's direction)",
                   "upon", False, tu, [_lever(g)]),
        constraint(f"leverfreed_{g.tap}", f"{name} is released: the grasp point at least "
                   f"{fr['release_dist'] * 100:.0f} cm from its lever", "upon", False, fr, [GRIP_TIP, _lever(g)]),
    ]


# --- templates ---------------------------------------------------------------------------------------------
def leverstill(c: Spec) -> str:
    """Parts: [lever (line)]. It has not moved since the grasp began."""
    (x,) = c["element_ids"][:1]
    mx, xn = num(c["thresholds"]["max_disp"]), obj_name(c, 0)
    body = f"""
    m = displacement(H[{x}])
    if m <= {mx}:
        return True, {lit("the lever of " + xn + " stays where it was (moved %.3f m)")} % m, {mx} - m
    return False, {lit("the lever of " + xn + " moved %.3f m before it was gripped: the jaws will close on nothing")} % m, {mx} - m
"""
    return check_fn(c, body)


def otherstill(c: Spec) -> str:
    """Parts: [the other handle (point)]. It has not moved since the subgoal began."""
    (x,) = c["element_ids"][:1]
    mx, xn = num(c["thresholds"]["max_disp"]), obj_name(c, 0)
    body = f"""
    m = displacement(H[{x}])
    if m <= {mx}:
        return True, {lit("the other handle of " + xn + " stays closed (moved %.3f m)")} % m, {mx} - m
    return False, {lit("the other handle of " + xn + " moved %.3f m: the wrong tap is being turned")} % m, {mx} - m
"""
    return check_fn(c, body)


def levergrip(c: Spec) -> str:
    """Parts: [tip (point), lever (line)]. The lever's middle is at the grasp point."""
    tip, x = c["element_ids"][:2]
    md, xn = num(c["thresholds"]["max_dist"]), obj_name(c, 1)
    body = f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    if d <= {md}:
        return True, {lit("the lever of " + xn + " is between the fingers (%.3f m from the grasp point)")} % d, {md} - d
    return False, {lit("the named lever of " + xn + " is not between the fingers: %.3f m from the grasp point (limit " + md + ")")} % d, {md} - d
"""
    return check_fn(c, body)


def _turn_lines(x: int) -> str:
    return f"""
    u0 = direction(H[{x}][0])
    u1 = direction(E[{x}])
    a = angle_between(np.array([u0[0], u0[1], 0.0]), np.array([u1[0], u1[1], 0.0]))
"""


def levered(c: Spec) -> str:
    """Parts: [tip (point), lever (line)]. The lever stays at the grasp point unless it has turned ``min_turn``."""
    tip, x = c["element_ids"][:2]
    md, mt, xn = num(c["thresholds"]["max_dist"]), num(c["thresholds"]["min_turn"]), obj_name(c, 1)
    body = _turn_lines(x) + f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    margin = np.max([{md} - d, a - {mt}])
    if d <= {md} or a >= {mt}:
        return True, {lit("the lever of " + xn + " is in the gripper or turned (%.3f m from the grasp point, turned %.0f degrees)")} % (d, math.degrees(a)), margin
    return False, {lit("the lever of " + xn + " slipped out of the gripper: %.3f m from the grasp point, turned only %.0f degrees")} % (d, math.degrees(a)), margin
"""
    return check_fn(c, body)


def turned(c: Spec) -> str:
    """Parts: [lever (line)]. Its horizontal direction turned ``min_turn`` (and at most ``max_turn``, when given)
    since the turn began."""
    (x,) = c["element_ids"][:1]
    mt, xn = num(c["thresholds"]["min_turn"]), obj_name(c, 0)
    over = ""
    if "max_turn" in c["thresholds"]:
        xt = num(c["thresholds"]["max_turn"])
        over = f"""
    if a > {xt}:
        return False, {lit("the lever of " + xn + " turned %.0f degrees, past the %.0f asked for")} % (math.degrees(a), math.degrees({xt})), {xt} - a"""
    body = _turn_lines(x) + over + f"""
    if a >= {mt}:
        return True, {lit("the lever of " + xn + " turned %.0f degrees")} % math.degrees(a), a - {mt}
    return False, {lit("the lever of " + xn + " turned only %.0f degrees (needs %.0f)")} % (math.degrees(a), math.degrees({mt})), a - {mt}
"""
    return check_fn(c, body)


def leverfreed(c: Spec) -> str:
    return freed(c, "the lever of " + obj_name(c, 1))


# --- the rule ----------------------------------------------------------------------------------------------
def next_subgoal(goal: TapGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    side = goal.part.split("_")[0]
    g = answer(f"grasp the lever of the {side} tap", "grasp", {"obj": goal.tap, "part": goal.part}, grasp(goal), "")
    t = answer(f"turn the {side} tap {goal.angle:g} degrees open", "turn",
               {"obj": goal.tap, "part": goal.part, "angle": goal.angle}, turn(goal), "")
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in ("grasp", "turn"):
        if previous and previous.get("done"):
            return done(f"the {side} tap is open")
        how = "a quarter-turn" if goal.quarter_turn else f"{goal.angle:g} degrees"
        g["reasoning"] = f"grasp the {side} tap's lever, then turn it outwards {how}"
        return g
    kind = failed_kind(feedback)
    if kind == "success":
        if skill == "grasp":
            t["reasoning"] = "the lever is held; turn it about its hinge, outwards, then let go"
            return t
        return done(f"the {side} tap is open")
    if kind == "leverfreed":
        t["reasoning"] = "the lever is still held; turn again, which ends by letting go"
        return t
    g["reasoning"] = f"the {side} tap's lever is not held or not turned far enough ({kind}); grasp it again"
    return g


FAMILY = TaskFamily(
    name="tap",
    task="turn-tap",
    summary="turn the left or the right tap open",
    example="turn the left tap",
    understand=understand,
    next_subgoal=next_subgoal,
    scene=scene,
    task_params=lambda goal: {"side": goal.part.split("_")[0],
                              **({} if goal.quarter_turn else {"angle": goal.angle})},
    thresholds=THRESHOLDS,
    templates={"leverstill": leverstill, "otherstill": otherstill, "levergrip": levergrip, "levered": levered,
               "turned": turned, "leverfreed": leverfreed},
)
