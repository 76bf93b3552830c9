"""Constraint builders per skill: the constraints, parts, element kinds and thresholds of a subgoal.

Each builder returns constraint dicts in the generator's JSON answer format (see
:mod:`code_as_monitor.vlm.schemas`). Constraint ids start with a template key (``held_``,
``attached_``, ...) that :mod:`code_as_monitor.vlm.kb.templates` uses to write the check; new skills
add a builder here and a template there.
"""

from __future__ import annotations

import math
from typing import Any

from code_as_monitor.vlm.kb.thresholds import thresholds

TIP = {"name": "suction cup tip", "obj": "robot", "part": "tip", "kind": "point"}


def nice(obj: str) -> str:
    """Human form of an object name: ``green_block`` -> ``the green block``."""
    return "the " + obj.replace("_", " ")


def whole(obj: str) -> dict[str, str]:
    """A whole object abstracted as one point (its centre)."""
    return {"name": obj.replace("_", " "), "obj": obj, "part": "", "kind": "point"}


def _c(cid: str, text: str, phase: str, proactive: bool, thr: dict[str, float], parts: list[dict]) -> dict[str, Any]:
    return {"id": cid, "text": text, "phase": phase, "proactive": proactive, "thresholds": thr, "parts": parts}


def pick(obj: str) -> list[dict[str, Any]]:
    """``pick``: upon, the object is on the suction cup and lifted."""
    thr = thresholds("held")
    return [
        _c(
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
    att, still, cen = thresholds("attached"), thresholds("still"), thresholds("centred")
    rest, rel = thresholds("resting"), thresholds("released")
    out = [
        _c(
            f"attached_{obj}",
            f"{nice(obj)} stays attached to the suction cup until it rests on {nice(target)}",
            "during", False, att, [TIP, whole(obj), whole(target)],
        ),
        _c(
            f"still_{target}",
            f"{nice(target)} (the block below) stays in place, within {still['max_disp'] * 100:.0f} cm; if it is "
            f"pushed, stacking on it will topple",
            "during", True, still, [whole(target)],
        ),
        _c(
            f"centred_{obj}_on_{target}",
            f"{nice(obj)} is centred on {nice(target)} within {cen['max_offset'] * 100:.1f} cm; an offset block "
            f"makes the tower topple when the next block lands",
            "upon", True, cen, [whole(obj), whole(target)],
        ),
        _c(
            f"resting_{obj}_on_{target}",
            f"{nice(obj)} rests on {nice(target)}: its centre one block above the centre of {nice(target)}",
            "upon", False, rest, [whole(obj), whole(target)],
        ),
        _c(
            f"released_{obj}",
            f"{nice(obj)} is released: the suction cup tip is at least {rel['release_dist'] * 100:.0f} cm from its "
            f"centre",
            "upon", False, rel, [TIP, whole(obj)],
        ),
    ]
    tower = thresholds("tower")
    for upper, lower in tower_below:
        out.append(
            _c(
                f"tower_{upper}_on_{lower}",
                f"{nice(upper)} is still on {nice(lower)} (the tower has not collapsed)",
                "during", False, tower, [whole(upper), whole(lower)],
            )
        )
    return out


def sweep_bounds(n_blocks: int) -> tuple[int, int, int, str]:
    """``(lower, upper, target, why)`` for "half of the blocks, within +-10 % of all blocks"."""
    thr = thresholds("count")
    half = n_blocks * thr["fraction"]
    tol = n_blocks * thr["tolerance_fraction"]
    lower, upper = math.ceil(half - tol), math.floor(half + tol)
    target = max(lower, round(half - thr["aim_below_centre"] * tol))
    why = (
        f"half of {n_blocks} blocks is {half:g}, accepted {lower}-{upper} (+-10 % of all blocks); the monitor "
        f"halts at {target}, below the centre, because pushes in flight when the policy stops still carry "
        f"blocks into the zone"
    )
    return lower, upper, target, why


def push_into_region(blocks: tuple[str, ...], region: str) -> tuple[list[dict[str, Any]], str]:
    """``push_into_region``: upon, the count inside the region reaches the target; during, not above the band."""
    lower, upper, target, why = sweep_bounds(len(blocks))
    zone = {"name": f"{region} surface", "obj": region, "part": "surface", "kind": "surface"}
    parts = [zone] + [whole(b) for b in blocks]
    thr = {"target": float(target), "lower": float(lower), "upper": float(upper), "total": float(len(blocks))}
    cons = [
        _c(
            f"reached_half_in_{region}",
            f"at least {target} of the {len(blocks)} blocks are inside {nice(region)} (half, accepted {lower}-{upper})",
            "upon", False, thr, parts,
        ),
        _c(
            f"capped_in_{region}",
            f"no more than {upper} blocks are inside {nice(region)}; more cannot be undone",
            "during", False, thr, parts,
        ),
    ]
    return cons, why


def close_shape(rope: str, shape: str, beads: tuple[str, ...]) -> list[dict[str, Any]]:
    """``close_shape``: upon, resting rope beads lie along (nearly) all of the opening between corner_3 and corner_0."""
    thr = thresholds("rope_cover")
    parts = [
        {"name": f"{shape} opening corner_0", "obj": shape, "part": "corner_0", "kind": "point"},
        {"name": f"{shape} opening corner_3", "obj": shape, "part": "corner_3", "kind": "point"},
    ] + [{"name": f"rope {b}", "obj": rope, "part": b, "kind": "point"} for b in beads]
    return [
        _c(
            "rope_covers_opening",
            f"{nice(rope)} closes the opening of {nice(shape)}: at least {thr['min_fraction'] * 100:.0f} % of "
            f"the opening (corner_3 to corner_0, corners included) has a resting rope bead within "
            f"{thr['max_gap'] * 100:.1f} cm, steadily for {thr['stable_s']:g} s",
            "upon", False, thr, parts,
        )
    ]


def answer(text: str, skill: str, args: dict[str, Any], cons: list[dict[str, Any]], why: str) -> dict[str, Any]:
    """The generator's JSON answer for one subgoal (the format a VLM is asked for)."""
    return {"subgoal": text, "done": False, "action": {"skill": skill, "args": args}, "constraints": cons,
            "reasoning": why}
