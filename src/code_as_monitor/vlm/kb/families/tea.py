# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``tea`` (task ``pour-tea`` (surface level)): understanding, constraint builders, thresholds, templates
and recovery.

Family ``tea`` ("pour the tea from the teapot into the teacup"): ``grasp`` the pot by its handle -> ``transport``
it level until its spout is above the cup -> ``pour`` (tilt it past the pour angle) -> ``drain`` (hold it tilted)
-> ``level`` it again -> done. Elements: the gripper's grasp point (``robot/tip``, point), the pot's handle
(``teapot/handle``, point), its lid (``teapot/lid``, a SURFACE: ``normal`` is the pot's up axis, its angle to
vertical the pot's tilt), its spout (``teapot/spout``, point) and the cup's opening (``teacup/rim``, a SURFACE;
its centroid is the cup's centre). Level is the lid normal within 15 degrees of vertical; tipped to pour is the
spout far enough below the handle (see the templates below). The tea itself is not an
element: the monitor watches the pot.

Recovery by the failed constraint's id prefix (``"failure: <id>: <reason>"``):

========================================================= ==============================================
failed                                                    next subgoal
========================================================= ==============================================
grasped/lifted (not in the gripper), gripped (dropped)     grasp again (where it is now)
potlevel in transport (tipped in the grasp),               level it with the wrist, then transport
spoutover while pouring/draining (pouring beside the cup)
potlevel after a level (the wrist could not level it: a    set it down (it lands on its floor), then grasp
sideways tilt)                                             it again
potlevel after setting it down                             grasp it again
spoutover (the spout is not above the cup)                 transport again
pourtilt (not tilted past the pour angle),                 pour again
draintilt (back towards level while draining)
freed (still held after setting it down)                   set it down again
========================================================= ==============================================

The kb is stateless: a ``level`` that recovers (its subgoal says it carries on afterwards) is followed by
``transport``, the final one by "task complete".

Thresholds: Physical tolerances from the object sizes in sim/assets (``teapot.urdf``: an 11 cm pot, its spout a 9 cm trough
rising 35 degrees, the handle a 5 x 5 cm fin; ``teacup.urdf``: an 8.2 cm opening, 7 cm tall), never fitted to
evaluation outcomes. Units: metres, radians, fractions.

Templates: Element order in a constraint's parts is the contract with the builders above: ``lid`` is a
SURFACE (the corners of the pot's lid; ``normal`` gives the pot's up axis, ``angle_to_vertical`` its tilt),
``spout`` a point (the trough's centre), ``rim`` a SURFACE (the cup's opening; its centroid is the cup's centre).
Level is the lid normal's angle to vertical (any direction). Tipped to pour is measured along the pot instead:
the slope of the line from the handle's centre to the spout's centre, about horizontal when the pot is level and
as steep as the forward tilt when it pours (measured on simulator frames: within 5 degrees of the pot's tilt). The
lid normal cannot tell a pot tipped spout-down from one tipped back, and a check that asks for a large tilt of a
surface from a level start is one that path coverage's probes (translations; a surface rotated on a few of them)
rarely drive to True, so the coder's program would be rejected; points moved up or down do drive it.
A tilt's direction in transport (along the spout or sideways) is not told apart: the kb levels the pot with the
wrist first and sets it down when that does not work (see the rule above).
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
from code_as_monitor.vlm.kb.shared.grip import GRIP_TIP, in_gripper, part_spec, still_gripped
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

SPOUT_SLOPE = math.radians(35.0)
"""The spout trough's rise above the pot's floor plane: tilted forward past this, the trough slopes down and
the tea runs out."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # grasp, upon: the handle's (painted) centre within 4 cm of the grasp point (the fin is 5 x 5 cm: the centre
    # of its visible faces can be 2.5 cm off its true centre) and risen 5 cm with it since the grasp began (the
    # handle is at 5 cm when the pot stands on the table; the grasp lifts it to 22 cm).
    "teapot_lifted": {"max_dist": 0.04, "min_rise": 0.05},
    # transport, pour, drain, level, during: the handle stays within 5 cm of the grasp point; a dropped pot
    # falls to the table, 10 cm or more below it.
    "teapot_gripped": {"max_dist": 0.05},
    # transport, during: the lid (its normal) within 15 degrees of vertical: "level within 15 degrees"; at 35
    # degrees forward the trough slopes down and the tea runs out.
    "teapot_carried_level": {"max_tilt": math.radians(15.0)},
    # level and set_down, upon: the lid within 15 degrees of vertical (the same "level").
    "teapot_level": {"max_tilt": math.radians(15.0)},
    # transport, upon, and pour, drain, during (proactive): the spout's (painted) centre within 8 cm
    # (horizontally) of the cup's centre: the opening's half-width (4.1 cm) plus the 4 cm the trough's centre lies
    # behind its end (4.5 cm along a 35-degree slope), where the tea leaves.
    "spout_over_cup": {"max_offset": 0.08},
    # pour, upon: tipped forward at least 50 degrees (the handle-to-spout line, about horizontal when level, slopes
    # down that much): the trough, rising SPOUT_SLOPE when level, then slopes 15 degrees down and the tea rolls out.
    "teapot_poured": {"min_tilt": math.radians(50.0)},
    # drain, during: it stays tipped at least 40 degrees (the trough 5 degrees down, the tea still runs);
    # back towards level the tea stops and rolls back into the pot.
    "teapot_draining": {"min_tilt": math.radians(40.0)},
    # set_down, upon: let go: the grasp point at least 6 cm from the handle's centre (beyond its 4 cm slack).
    "teapot_freed": {"release_dist": 0.06},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


CARRY_ON = "then carry it on to"
"""Words in the subgoal of a recovering ``level`` (followed by ``transport``, not by the end of the task)."""
TEA_SKILLS = ("grasp", "transport", "pour", "drain", "level", "set_down")


@dataclass(frozen=True)
class TeaGoal:
    """The pot poured from and the cup poured into."""

    obj: str
    target: str


VERBS = ("pour", "fill", "grasp", "pick", "tilt")  # tilting the pot is how it pours: said with "pour", it adds nothing
HEADS = ("tea", "teapot", "teacup", "pot", "cup")
DOING = "pours the tea from the teapot into the teacup"


def claims(ins: Instruction) -> bool:
    return bool({"tea", "teapot", "teacup"} & ins.heads) or "pour" in ins.verbs


def understand(ins: Instruction, objects: list[str]) -> TeaGoal | None:
    """The pot and cup grounded on ``objects``; None when the instruction is not about pouring tea.

    Reads "pour (the tea) from the teapot into the teacup", "pour the teapot into the cup", "fill the cup (with
    tea) from the pot", "pour a cup of tea"; a cup or pot left unsaid is the scene's only one."""
    if not claims(ins):
        return None
    r = Reading(ins, "pour-tea", heads=HEADS, verbs=VERBS)
    r.verbs(VERBS, DOING, once=True)
    r.modifiers((), DOING)
    names = scene_names(objects)
    pot = next((o for o in names if "pot" in o), "")
    cup = next((o for o in names if "cup" in o and "holder" not in o), "")
    if not pot or not cup:
        r.refuse("the scene has no teapot" if not pot else "the scene has no teacup")
    pots = r.phrases(lambda p: p.head in ("teapot", "pot"))
    cups = r.phrases(lambda p: p.head in ("teacup", "cup"))
    teas = r.phrases(lambda p: p.head == "tea")
    for p in pots + cups + teas:
        q = ins.resolve(p.index)
        if q.colour or q.position or q.ordinal or (q.quantity is not None and q.quantity.kind not in ("all", "some")) \
                or (q.plural and q.head != "tea") or (q.quantity is not None and q.quantity.of_total is not None):
            r.refuse(f"{p.text!r}: the kb pours all the tea from the one teapot into the one teacup")
        r.use(p.index)
    if not ins.verbs or not {"pour", "fill"} & set(ins.verbs):
        r.refuse("say what to do with the tea: pour it")
    if "fill" in ins.verbs and not cups:
        r.refuse("fill what? the teacup")
    for k in ins.links:
        a = ins.resolve(k.a).head if k.a is not None else ""
        b = ins.resolve(k.b).head
        if (k.kind == "from" and b in ("teapot", "pot")) or (k.kind in ("into", "to", "on") and b in ("teacup", "cup")) \
                or (k.kind == "with" and b == "tea") or (k.kind == "of" and a in ("teacup", "cup") and b == "tea"):
            r.use_link(k)
    r.finish()
    return TeaGoal(pot, cup)


def scene(ins: Instruction) -> list[str] | None:
    """The pour-tea scene's objects, or None."""
    return ["teapot", "teacup", "table"] if claims(ins) else None


def _handle(obj: str) -> dict[str, str]:
    return part_spec(obj, "handle", "point", "handle")


def _lid(obj: str) -> dict[str, str]:
    return part_spec(obj, "lid", "surface", "lid")


def _spout(obj: str) -> dict[str, str]:
    return part_spec(obj, "spout", "point", "spout")


def _rim(obj: str) -> dict[str, str]:
    return part_spec(obj, "rim", "surface", "opening")


def grasp(obj: str) -> list[dict[str, Any]]:
    """``grasp``: upon, the handle is at the grasp point and lifted."""
    return in_gripper(obj, _handle(obj), _thr("teapot_lifted"))


def transport(obj: str, target: str) -> list[dict[str, Any]]:
    """``transport``: during, gripped and level (lid normal within 15 degrees of vertical); upon, the spout is
    above the cup."""
    gr, lv, ov = _thr("teapot_gripped"), _thr("teapot_carried_level"), _thr("spout_over_cup")
    return [
        still_gripped(obj, _handle(obj), gr),
        constraint(f"potlevel_{obj}", f"{nice(obj)} stays level while carried: its lid within "
           f"{round(math.degrees(lv['max_tilt']))} degrees of horizontal (tipped forward, the tea runs out of the "
           f"spout)", "during", False, lv, [_lid(obj)]),
        constraint(f"spoutover_{target}", f"the spout of {nice(obj)} is above {nice(target)} (its centre within "
           f"{ov['max_offset'] * 100:.0f} cm of the cup's centre, horizontally)", "upon", False, ov,
           [_spout(obj), _rim(target)]),
    ]


def _over_while_pouring(obj: str, target: str) -> dict[str, Any]:
    ov = _thr("spout_over_cup")
    return constraint(f"spoutover_{target}", f"the spout of {nice(obj)} stays above {nice(target)} (its centre within "
              f"{ov['max_offset'] * 100:.0f} cm of the cup's centre) while it pours, or the tea lands beside it",
              "during", True, ov, [_spout(obj), _rim(target)])


def pour(obj: str, target: str) -> list[dict[str, Any]]:
    """``pour``: during, gripped and the spout over the cup; upon, tilted past the pour angle."""
    gr, pd = _thr("teapot_gripped"), _thr("teapot_poured")
    return [
        still_gripped(obj, _handle(obj), gr),
        _over_while_pouring(obj, target),
        constraint(f"pourtilt_{obj}", f"{nice(obj)} is tipped past the pour angle: its spout at least "
           f"{round(math.degrees(pd['min_tilt']))} degrees below its handle", "upon", False, pd,
           [_handle(obj), _spout(obj)]),
    ]


def drain(obj: str, target: str) -> list[dict[str, Any]]:
    """``drain``: during, gripped, still tilted to pour and the spout over the cup (no upon: it ends on time)."""
    gr, dr = _thr("teapot_gripped"), _thr("teapot_draining")
    return [
        still_gripped(obj, _handle(obj), gr),
        constraint(f"draintilt_{obj}", f"{nice(obj)} stays tipped (its spout at least {round(math.degrees(dr['min_tilt']))} "
           f"degrees below its handle) while the tea runs out", "during", False, dr, [_handle(obj), _spout(obj)]),
        _over_while_pouring(obj, target),
    ]


def level(obj: str) -> list[dict[str, Any]]:
    """``level``: during, gripped; upon, the lid within 15 degrees of horizontal."""
    gr, lv = _thr("teapot_gripped"), _thr("teapot_level")
    return [
        still_gripped(obj, _handle(obj), gr),
        constraint(f"potlevel_{obj}", f"{nice(obj)} is level: its lid within {round(math.degrees(lv['max_tilt']))} degrees of "
           f"horizontal", "upon", False, lv, [_lid(obj)]),
    ]


def set_down(obj: str) -> list[dict[str, Any]]:
    """``set_down``: upon, let go and standing level on the table."""
    fr, lv = _thr("teapot_freed"), _thr("teapot_level")
    return [
        constraint(f"freed_{obj}", f"{nice(obj)} is let go: the grasp point at least {fr['release_dist'] * 100:.0f} cm from "
           f"its handle", "upon", False, fr, [GRIP_TIP, _handle(obj)]),
        constraint(f"potlevel_{obj}", f"{nice(obj)} stands level on the table: its lid within "
           f"{round(math.degrees(lv['max_tilt']))} degrees of horizontal", "upon", False, lv, [_lid(obj)]),
    ]


# --- the rule --------------------------------------------------------------------------------------------
REGRASP = ("grasped", "lifted", "gripped")


def next_tea(obj: str, target: str, previous: dict[str, Any] | None, kind: str) -> dict[str, Any]:
    """The next subgoal; ``kind`` is the failed constraint's key (or ``success``)."""
    g = answer(f"grasp {nice(obj)} by its handle", "grasp", {"obj": obj, "part": "handle"}, grasp(obj), "")
    t = answer(f"carry {nice(obj)} level until its spout is above {nice(target)}", "transport",
               {"obj": obj, "target": target}, transport(obj, target), "")
    p = answer(f"tilt {nice(obj)} to pour into {nice(target)}", "pour", {"obj": obj, "target": target},
               pour(obj, target), "")
    d = answer(f"hold {nice(obj)} tilted over {nice(target)} while the tea runs out", "drain",
               {"obj": obj, "target": target}, drain(obj, target), "")
    fin = answer(f"level {nice(obj)} again after pouring", "level", {"obj": obj}, level(obj), "")
    again = answer(f"level {nice(obj)} in the gripper, {CARRY_ON} {nice(target)}", "level", {"obj": obj},
                   level(obj), "")
    down = answer(f"set {nice(obj)} down on the table", "set_down", {"obj": obj}, set_down(obj), "")
    end = done("the tea is poured into the cup")
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in TEA_SKILLS:
        if previous and previous.get("done"):
            return end
        g["reasoning"] = "the teapot stands on the table: grasp it by its handle, carry it level to the cup, pour"
        return g
    recovering = CARRY_ON in str(previous.get("text") or previous.get("subgoal") or "")
    if kind == "success":
        nxt = {"grasp": t, "transport": p, "pour": d, "drain": fin, "set_down": g}.get(skill)
        if nxt is not None:
            nxt["reasoning"] = f"the {skill} is done; next: {nxt['subgoal']}"
            return nxt
        if recovering:
            t["reasoning"] = "the pot is level again; carry it on until the spout is above the cup"
            return t
        return end
    if kind in REGRASP or (skill == "grasp" and kind == "other"):
        g["reasoning"] = f"the teapot is not in the gripper ({kind}); grasp it again where it is now"
        return g
    if kind == "potlevel" and skill == "transport":
        again["reasoning"] = ("the pot tipped in the grasp while carried: turn the wrist until it is level (a tilt "
                              "towards or away from the spout), then carry it on")
        return again
    if kind == "spoutover" and skill in ("pour", "drain"):
        again["reasoning"] = "the pot pours beside the cup: level it, then carry it on until the spout is above the cup"
        return again
    if kind == "potlevel" and skill == "level":
        down["reasoning"] = ("the wrist cannot level the pot: it is tipped sideways in the grasp; set it down so it "
                             "stands on its floor, then grasp it again")
        return down
    if kind == "potlevel" and skill == "set_down":
        g["reasoning"] = "the pot did not land level; grasp it again as it stands"
        return g
    if kind == "freed" or (skill == "set_down" and kind == "other"):
        down["reasoning"] = "the pot is still held; set it down again"
        return down
    if kind == "spoutover" or (skill == "transport" and kind == "other"):
        t["reasoning"] = "the spout is not above the cup; carry the pot on until it is"
        return t
    if kind in ("pourtilt", "draintilt") or (skill in ("pour", "drain") and kind == "other"):
        p["reasoning"] = f"the pot is not tilted far enough to pour ({kind}); tilt it to pour again"
        return p
    nxt = {"level": again if recovering else fin}.get(skill, g)
    nxt["reasoning"] = f"the {skill} did not finish ({kind}); try again"
    return nxt



def next_subgoal(goal: TeaGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    return next_tea(goal.obj, goal.target, previous, failed_kind(feedback))


# --- templates ---------------------------------------------------------------------------------------------
def potlevel(c: Spec) -> str:
    """Parts: [lid (surface)]. The lid's normal is within ``max_tilt`` of vertical (the pot stands level)."""
    (lid,) = c["element_ids"][:1]
    th, xn = c["thresholds"], obj_name(c, 0)
    mt = num(th["max_tilt"])
    body = f"""
    a = angle_to_vertical(normal(E[{lid}]))
    if a <= {mt}:
        return True, {lit(xn + " is level (its lid %.1f degrees from horizontal)")} % math.degrees(a), {mt} - a
    return False, {lit(xn + " is not level: its lid is tilted %.1f degrees")} % math.degrees(a), {mt} - a
"""
    return check_fn(c, body)


def spoutover(c: Spec) -> str:
    """Parts: [spout (point), rim (surface)]. The spout is above the cup: within ``max_offset`` horizontally."""
    spout, rim = c["element_ids"][:2]
    th, xn, rn = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    mo = num(th["max_offset"])
    body = f"""
    off = horizontal_distance(E[{spout}], centroid(E[{rim}]))
    if off <= {mo}:
        return True, {lit("the spout of " + xn + " is above " + rn + " (%.3f m from its centre)")} % off, {mo} - off
    return False, {lit("the spout of " + xn + " is not above " + rn + ": %.3f m from its centre")} % off, {mo} - off
"""
    return check_fn(c, body)


def _tilted(c: Spec, failure: str) -> str:
    """Parts: [handle (point), spout (point)]. The pot is tipped spout-down by at least ``min_tilt``: the line from
    the handle to the spout (about horizontal when the pot is level) slopes down that much. ``failure`` is the
    reason when it does not, with ``%.1f`` for the slope in degrees."""
    handle, spout = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 0)
    mt = num(th["min_tilt"])
    body = f"""
    d = centroid(E[{spout}]) - centroid(E[{handle}])
    a = math.atan2(-d[2], math.hypot(d[0], d[1]))
    if a >= {mt}:
        return True, {lit(xn + " is tipped to pour: its spout %.1f degrees below its handle")} % math.degrees(a), a - {mt}
    return False, {lit(xn + failure)} % math.degrees(a), a - {mt}
"""
    return check_fn(c, body)


def pourtilt(c: Spec) -> str:
    """Upon the pour: tilted past the pour angle."""
    return _tilted(c, " is tipped only %.1f degrees spout-down: not past the pour angle, the tea does not run out")


def draintilt(c: Spec) -> str:
    """During the drain: still tilted past the pour angle."""
    return _tilted(c, " went back towards level (spout %.1f degrees below the handle) while draining: the tea stops running")


FAMILY = TaskFamily(
    name="tea",
    task="pour-tea",
    summary="pour the tea from the teapot into the teacup",
    example="pour the tea from the teapot into the teacup",
    understand=understand,
    next_subgoal=next_subgoal,
    scene=scene,
    thresholds=THRESHOLDS,
    templates={"potlevel": potlevel, "spoutover": spoutover, "pourtilt": pourtilt, "draintilt": draintilt},
)
