# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``stack`` (task ``stack-in-order``): stack coloured blocks with the suction cup, bottom first.

Plan: the bottom block stays on the table; for each next level ``pick`` the block, then ``place_on`` the one
below -> done. Elements: the suction cup's tip (``robot/tip``) and each block as a point (its centre).

Recovery (by the category of the feedback, :func:`~code_as_monitor.vlm.kb.shared.feedback.classify`):
collapse -> restart from the lowest tower level named in the feedback; offset -> pick the misplaced block
again and re-place it; dropped -> pick it again; anything else after a placement -> place again.

Thresholds are the paper's "manually initialized thresholds for common tasks in an external knowledge base"
(supplementary, failure threshold selection): physical tolerances from the task geometry (block edge about
4 cm, suction cup contact at the block's top face), never fitted to evaluation outcomes. Metres.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import TIP, answer, constraint, done, nice, whole
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name
from code_as_monitor.vlm.kb.shared.feedback import classify, mentioned

COLOURS = ("red", "green", "blue", "yellow", "orange", "purple", "pink", "white", "black", "brown", "gray", "cyan")
BLOCK_SIZE = 0.04
"""Nominal edge of a stacking block (m); the height tests below are expressed in block sizes."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # pick: the block is on the suction cup and off the table.
    "held": {
        "max_dist": 0.04,  # tip to block centre: half a block (contact) plus 2 cm slack
        "min_z": 0.05,  # block centre height: resting centre (2 cm) plus 3 cm lift
    },
    # place_on, during: the carried block stays on the cup until it rests on the target.
    "attached": {
        "max_dist": 0.05,  # tip to block centre while carried (looser than "held": the cup swings)
        "release_xy": 0.03,  # a release within 3 cm of the target centre counts as "placed"
        "min_dz": 0.5 * BLOCK_SIZE,  # block above target by 0.5 ... 1.5 block sizes = resting on it
        "max_dz": 1.5 * BLOCK_SIZE,
    },
    # place_on, during (proactive): the block below must not be pushed while we stack on it.
    "still": {"max_disp": 0.02},
    # place_on, upon (proactive): an off-centre block makes the next level topple. 1 cm is CLIPort's
    # position tolerance for a placed block (the simulator's tower check uses the same figure).
    "centred": {"max_offset": 0.01},
    # place_on, upon: the block sits one block size above the target's centre ...
    "resting": {"min_dz": 0.5 * BLOCK_SIZE, "max_dz": 1.5 * BLOCK_SIZE},
    # ... and the cup has let go (the tip is further from the block centre than at contact).
    "released": {"release_dist": 0.04},
    # place_on, during: lower levels of the tower stay stacked (reactive collapse detection).
    "tower": {"max_offset": 0.025, "min_dz": 0.5 * BLOCK_SIZE, "max_dz": 1.5 * BLOCK_SIZE},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


@dataclass(frozen=True)
class StackGoal:
    """The tower to build: block names, bottom first."""

    tower: tuple[str, ...]


# --- understanding -----------------------------------------------------------------------------------------
def tower_order(instruction: str, objects: list[str]) -> tuple[str, ...]:
    """Blocks bottom-first: colours in the order the instruction names them, grounded on ``objects``.

    "red at the bottom, then green, then blue" -> (red_block, green_block, blue_block). A colour named
    with "at the top" / "on top" is moved last.
    """
    s = instruction.lower()
    named = sorted((m.start(), c) for c in COLOURS for m in re.finditer(rf"\b{c}\b", s))
    order: list[str] = []
    for _, c in named:
        obj = next((o for o in objects if o.lower().startswith(f"{c}_") or o.lower() == c), None)
        if obj is not None and obj not in order:
            order.append(obj)
    for c in COLOURS:
        if re.search(rf"\b{c}\b[^,.;]*\b(at the top|on top)\b", s):
            obj = next((o for o in order if o.lower().startswith(c)), None)
            if obj is not None:
                order.remove(obj)
                order.append(obj)
    return tuple(order)


def understand(ins: Instruction, objects: list[str]) -> StackGoal | None:
    """The tower asked for, grounded on ``objects``; None when the instruction is not about stacking."""
    s = ins.lower
    if not ("stack" in s or "tower" in s):
        return None
    tower = tower_order(ins.text, [o for o in objects if "/" not in o])
    return StackGoal(tower) if len(tower) >= 2 else None


def scene(ins: Instruction) -> list[str] | None:
    """``<colour>_block`` for each colour named, in order, plus the table; None when no colour is named."""
    s = ins.lower
    colours = [c for _, c in sorted((s.find(c), c) for c in COLOURS if re.search(rf"\b{c}\b", s))]
    return [f"{c}_block" for c in colours] + ["table"] if colours else None


# --- constraint builders -----------------------------------------------------------------------------------
def pick(obj: str) -> list[dict[str, Any]]:
    """``pick``: upon, the object is on the suction cup and lifted."""
    thr = _thr("held")
    return [
        constraint(
            f"held_{obj}",
            f"{nice(obj)} is held by the suction cup: its centre within {thr['max_dist'] * 100:.0f} cm of the tip "
            f"and lifted above {thr['min_z'] * 100:.0f} cm",
            "upon", False, thr, [TIP, whole(obj)],
        )
    ]


def place_on(obj: str, target: str, tower_below: list[tuple[str, str]]) -> list[dict[str, Any]]:
    """``place_on`` a block: stays attached until placed, the block below stays put; lands centred, resting, released.

    The three upon constraints are separate single-decision checks so that all of them must hold
    before the subgoal counts as complete (a block hovering centred above the target is not placed).

    Args:
        obj: the carried block.
        target: the block it goes on.
        tower_below: (upper, lower) pairs already stacked under ``target`` that must stay stacked.
    """
    att, still, cen = _thr("attached"), _thr("still"), _thr("centred")
    rest, rel = _thr("resting"), _thr("released")
    out = [
        constraint(
            f"attached_{obj}",
            f"{nice(obj)} stays attached to the suction cup until it rests on {nice(target)}",
            "during", False, att, [TIP, whole(obj), whole(target)],
        ),
        constraint(
            f"still_{target}",
            f"{nice(target)} (the block below) stays in place, within {still['max_disp'] * 100:.0f} cm; if it is "
            f"pushed, stacking on it will topple",
            "during", True, still, [whole(target)],
        ),
        constraint(
            f"centred_{obj}_on_{target}",
            f"{nice(obj)} is centred on {nice(target)} within {cen['max_offset'] * 100:.1f} cm; an offset block "
            f"makes the tower topple when the next block lands",
            "upon", True, cen, [whole(obj), whole(target)],
        ),
        constraint(
            f"resting_{obj}_on_{target}",
            f"{nice(obj)} rests on {nice(target)}: its centre one block above the centre of {nice(target)}",
            "upon", False, rest, [whole(obj), whole(target)],
        ),
        constraint(
            f"released_{obj}",
            f"{nice(obj)} is released: the suction cup tip is at least {rel['release_dist'] * 100:.0f} cm from its "
            f"centre",
            "upon", False, rel, [TIP, whole(obj)],
        ),
    ]
    tower = _thr("tower")
    for upper, lower in tower_below:
        out.append(
            constraint(
                f"tower_{upper}_on_{lower}",
                f"{nice(upper)} is still on {nice(lower)} (the tower has not collapsed)",
                "during", False, tower, [whole(upper), whole(lower)],
            )
        )
    return out


# --- templates ---------------------------------------------------------------------------------------------
def held(c: Spec) -> str:
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 1)
    md, mz = num(th["max_dist"]), num(th["min_z"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    z = centroid(E[{x}])[2]
    margin = np.min([{md} - d, z - {mz}])
    if d <= {md} and z >= {mz}:
        return True, {lit(xn + " is held by the suction cup (%.3f m from the tip, lifted to %.3f m)")} % (d, z), margin
    return False, {lit(xn + " is not held by the suction cup: %.3f m from the tip (limit " + md + "), centre %.3f m above the table (needs " + mz + ")")} % (d, z), margin
"""
    return check_fn(c, body)


def attached(c: Spec) -> str:
    tip, x, tgt = c["element_ids"][:3]
    th, xn, tn = c["thresholds"], obj_name(c, 1), obj_name(c, 2)
    md, rxy, lo, hi = num(th["max_dist"]), num(th["release_xy"]), num(th["min_dz"]), num(th["max_dz"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    off = horizontal_distance(E[{x}], E[{tgt}])
    dz = centroid(E[{x}])[2] - centroid(E[{tgt}])[2]
    margin = np.max([{md} - d, np.min([{rxy} - off, dz - {lo}, {hi} - dz])])
    if d <= {md} or (off <= {rxy} and dz >= {lo} and dz <= {hi}):
        return True, {lit(xn + " is on the suction cup or was released onto " + tn + " (%.3f m from the tip)")} % d, margin
    return False, {lit(xn + " dropped: detached from the suction cup (%.3f m from the tip) before resting on " + tn)} % d, margin
"""
    return check_fn(c, body)


def still(c: Spec) -> str:
    (tgt,) = c["element_ids"][:1]
    th, tn = c["thresholds"], obj_name(c, 0)
    mx = num(th["max_disp"])
    body = f"""
    m = displacement(H[{tgt}])
    if m <= {mx}:
        return True, {lit(tn + " stays in place (moved %.3f m)")} % m, {mx} - m
    return False, {lit(tn + " moved %.3f m: the tower below is disturbed and stacking on it will topple")} % m, {mx} - m
"""
    return check_fn(c, body)


def centred(c: Spec) -> str:
    x, tgt = c["element_ids"][:2]
    th, xn, tn = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    mo = num(th["max_offset"])
    body = f"""
    off = horizontal_distance(E[{x}], E[{tgt}])
    if off <= {mo}:
        return True, {lit(xn + " is centred on " + tn + " (offset %.3f m)")} % off, {mo} - off
    return False, {lit(xn + " is offset %.3f m from the centre of " + tn + " (limit " + mo + "): stacking on it will topple")} % off, {mo} - off
"""
    return check_fn(c, body)


def resting(c: Spec) -> str:
    x, tgt = c["element_ids"][:2]
    th, xn, tn = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    lo, hi = num(th["min_dz"]), num(th["max_dz"])
    body = f"""
    dz = centroid(E[{x}])[2] - centroid(E[{tgt}])[2]
    margin = np.min([dz - {lo}, {hi} - dz])
    if dz >= {lo} and dz <= {hi}:
        return True, {lit(xn + " rests on " + tn + " (%.3f m above its centre)")} % dz, margin
    return False, {lit(xn + " is not resting on " + tn + ": its centre is %.3f m above the centre of " + tn + " (expected " + lo + " to " + hi + ")")} % dz, margin
"""
    return check_fn(c, body)


def released(c: Spec) -> str:
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 1)
    rd = num(th["release_dist"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    if d >= {rd}:
        return True, {lit(xn + " is released (the tip is %.3f m away)")} % d, d - {rd}
    return False, {lit(xn + " is still held by the suction cup (the tip is %.3f m from its centre)")} % d, d - {rd}
"""
    return check_fn(c, body)


def tower(c: Spec) -> str:
    up, lo_id = c["element_ids"][:2]
    th, un, ln = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    mo, lo, hi = num(th["max_offset"]), num(th["min_dz"]), num(th["max_dz"])
    body = f"""
    off = horizontal_distance(E[{up}], E[{lo_id}])
    dz = centroid(E[{up}])[2] - centroid(E[{lo_id}])[2]
    margin = np.min([{mo} - off, dz - {lo}, {hi} - dz])
    if off <= {mo} and dz >= {lo} and dz <= {hi}:
        return True, {lit(un + " is still on " + ln + " (offset %.3f m)")} % off, margin
    return False, {lit(un + " is no longer on " + ln + " (offset %.3f m, height difference %.3f m): the tower collapsed")} % (off, dz), margin
"""
    return check_fn(c, body)


# --- the rule ----------------------------------------------------------------------------------------------
def _pick(task: StackGoal, level: int, why: str) -> dict[str, Any]:
    obj = task.tower[level]
    return answer(f"pick up {nice(obj)}", "pick", {"obj": obj}, pick(obj), why)


def _place(task: StackGoal, level: int, why: str) -> dict[str, Any]:
    obj, target = task.tower[level], task.tower[level - 1]
    below = [(task.tower[i], task.tower[i - 1]) for i in range(1, level)]
    cons = place_on(obj, target, below)
    return answer(
        f"place {nice(obj)} on {nice(target)}",
        "place_on", {"obj": obj, "target": target}, cons, why,
    )


def next_stack(task: StackGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    tower = task.tower
    action = (previous or {}).get("action") or {}
    skill, args = action.get("skill"), action.get("args") or {}
    obj = args.get("obj")
    if not previous or skill not in ("pick", "place_on") or obj not in tower[1:]:
        if previous and previous.get("done"):
            return done("the tower is complete")
        return _pick(task, 1, f"{tower[0]} is the base and stays on the table; the next level is {tower[1]}")
    level = tower.index(obj)
    cat = classify(feedback)
    if cat == "collapse":
        levels = [tower.index(n) for n in mentioned(feedback, tower)]
        lowest = max(1, min(levels)) if levels else 1
        return _pick(task, lowest, f"the tower was disturbed; restart from the lowest level that may be missing, "
                                   f"{tower[lowest]} (level {lowest})")
    if skill == "pick":
        if cat == "success":
            return _place(task, level, f"{obj} is held; put it on {tower[level - 1]}")
        return _pick(task, level, f"{obj} is not held ({cat}); pick it again")
    # place_on
    if cat == "success":
        if level == len(tower) - 1:
            return done("every block is stacked in order")
        return _pick(task, level + 1, f"{obj} is placed; the next level is {tower[level + 1]}")
    if cat == "offset":
        return _pick(task, level, f"{obj} is off-centre, so the next block would topple the tower; pick it "
                                  f"again and re-place it")
    if cat == "dropped":
        return _pick(task, level, f"{obj} was dropped before it rested on {tower[level - 1]}; pick it again")
    return _place(task, level, f"the placement of {obj} did not finish ({cat}); place it again")


FAMILY = TaskFamily(
    name="stack",
    task="stack-in-order",
    summary="stack coloured blocks into a tower in a given order",
    example="stack the blocks: red at the bottom, then green, then blue",
    understand=understand,
    next_subgoal=next_stack,
    scene=scene,
    thresholds=THRESHOLDS,
    templates={"held": held, "attached": attached, "still": still, "centred": centred, "resting": resting,
               "released": released, "tower": tower},
    keywords=(("held by", "held"), ("attached", "attached"), ("stays in place", "still"), ("centred", "centred"),
              ("rests on", "resting"), ("released", "released"), ("still on", "tower")),
)
