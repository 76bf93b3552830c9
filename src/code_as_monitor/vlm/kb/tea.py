"""kb rules for ``pour-tea`` (surface level): understanding, constraint builders and the stateless next-subgoal rule.

Family ``tea`` ("pour the tea from the teapot into the teacup"): ``grasp`` the pot by its handle -> ``transport``
it level until its spout is above the cup -> ``pour`` (tilt it past the pour angle) -> ``drain`` (hold it tilted)
-> ``level`` it again -> done. Elements: the gripper's grasp point (``robot/tip``, point), the pot's handle
(``teapot/handle``, point), its lid (``teapot/lid``, a SURFACE: ``normal`` is the pot's up axis, its angle to
vertical the pot's tilt), its spout (``teapot/spout``, point) and the cup's opening (``teacup/rim``, a SURFACE;
its centroid is the cup's centre). Level is the lid normal within 15 degrees of vertical; tipped to pour is the
spout far enough below the handle (see :mod:`code_as_monitor.vlm.kb.tea_templates`). The tea itself is not an
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
"""

from __future__ import annotations

import math
from typing import Any

from code_as_monitor.vlm.kb.grip import GRIP_TIP, in_gripper, part_spec, still_gripped
from code_as_monitor.vlm.kb.skills import _c, answer, nice
from code_as_monitor.vlm.kb.thresholds import thresholds

CARRY_ON = "then carry it on to"
"""Words in the subgoal of a recovering ``level`` (followed by ``transport``, not by the end of the task)."""
TEA_SKILLS = ("grasp", "transport", "pour", "drain", "level", "set_down")


def understand(instruction: str, objects: list[str]) -> tuple[str, str] | None:
    """(pot, cup) grounded on ``objects`` when the instruction asks to pour tea, else None."""
    s = instruction.lower()
    if "pour" not in s or "tea" not in s:
        return None
    names = [o for o in objects if "/" not in o]
    pot = next((o for o in names if "pot" in o), "")
    cup = next((o for o in names if "cup" in o), "")
    return (pot, cup) if pot and cup else None


def infer_objects(instruction: str) -> list[str] | None:
    """The simulator's object list for this task's instruction, or None."""
    s = instruction.lower()
    if "pour" in s and "tea" in s:
        return ["teapot", "teacup", "table"]
    return None


# --- elements and constraint builders ------------------------------------------------------------------
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
    return in_gripper(obj, _handle(obj), thresholds("teapot_lifted"))


def transport(obj: str, target: str) -> list[dict[str, Any]]:
    """``transport``: during, gripped and level (lid normal within 15 degrees of vertical); upon, the spout is
    above the cup."""
    gr, lv, ov = thresholds("teapot_gripped"), thresholds("teapot_carried_level"), thresholds("spout_over_cup")
    return [
        still_gripped(obj, _handle(obj), gr),
        _c(f"potlevel_{obj}", f"{nice(obj)} stays level while carried: its lid within "
           f"{round(math.degrees(lv['max_tilt']))} degrees of horizontal (tipped forward, the tea runs out of the "
           f"spout)", "during", False, lv, [_lid(obj)]),
        _c(f"spoutover_{target}", f"the spout of {nice(obj)} is above {nice(target)} (its centre within "
           f"{ov['max_offset'] * 100:.0f} cm of the cup's centre, horizontally)", "upon", False, ov,
           [_spout(obj), _rim(target)]),
    ]


def _over_while_pouring(obj: str, target: str) -> dict[str, Any]:
    ov = thresholds("spout_over_cup")
    return _c(f"spoutover_{target}", f"the spout of {nice(obj)} stays above {nice(target)} (its centre within "
              f"{ov['max_offset'] * 100:.0f} cm of the cup's centre) while it pours, or the tea lands beside it",
              "during", True, ov, [_spout(obj), _rim(target)])


def pour(obj: str, target: str) -> list[dict[str, Any]]:
    """``pour``: during, gripped and the spout over the cup; upon, tilted past the pour angle."""
    gr, pd = thresholds("teapot_gripped"), thresholds("teapot_poured")
    return [
        still_gripped(obj, _handle(obj), gr),
        _over_while_pouring(obj, target),
        _c(f"pourtilt_{obj}", f"{nice(obj)} is tipped past the pour angle: its spout at least "
           f"{round(math.degrees(pd['min_tilt']))} degrees below its handle", "upon", False, pd,
           [_handle(obj), _spout(obj)]),
    ]


def drain(obj: str, target: str) -> list[dict[str, Any]]:
    """``drain``: during, gripped, still tilted to pour and the spout over the cup (no upon: it ends on time)."""
    gr, dr = thresholds("teapot_gripped"), thresholds("teapot_draining")
    return [
        still_gripped(obj, _handle(obj), gr),
        _c(f"draintilt_{obj}", f"{nice(obj)} stays tipped (its spout at least {round(math.degrees(dr['min_tilt']))} "
           f"degrees below its handle) while the tea runs out", "during", False, dr, [_handle(obj), _spout(obj)]),
        _over_while_pouring(obj, target),
    ]


def level(obj: str) -> list[dict[str, Any]]:
    """``level``: during, gripped; upon, the lid within 15 degrees of horizontal."""
    gr, lv = thresholds("teapot_gripped"), thresholds("teapot_level")
    return [
        still_gripped(obj, _handle(obj), gr),
        _c(f"potlevel_{obj}", f"{nice(obj)} is level: its lid within {round(math.degrees(lv['max_tilt']))} degrees of "
           f"horizontal", "upon", False, lv, [_lid(obj)]),
    ]


def set_down(obj: str) -> list[dict[str, Any]]:
    """``set_down``: upon, let go and standing level on the table."""
    fr, lv = thresholds("teapot_freed"), thresholds("teapot_level")
    return [
        _c(f"freed_{obj}", f"{nice(obj)} is let go: the grasp point at least {fr['release_dist'] * 100:.0f} cm from "
           f"its handle", "upon", False, fr, [GRIP_TIP, _handle(obj)]),
        _c(f"potlevel_{obj}", f"{nice(obj)} stands level on the table: its lid within "
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
    done = {"subgoal": "task complete", "done": True, "action": None, "constraints": [],
            "reasoning": "the tea is poured into the cup"}
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in TEA_SKILLS:
        if previous and previous.get("done"):
            return done
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
        return done
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
