
"""kb family ``sweep`` (task ``sweep-half``): push blocks into a marked region with the spatula until about half
of them are inside.

Plan: one ``push_into_region`` subgoal; upon, the count inside the region reaches the target; during, it does not
exceed the accepted band (blocks pushed in cannot be taken out). Elements: the region's surface and every block
as a point. Recovery: keep pushing until the count is reached; past the band there is nothing to undo, stop.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice, whole
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn
from code_as_monitor.vlm.kb.shared.feedback import classify

SWEEP_BLOCKS = 40
"""Blocks in the simulator's sweep-half scene (used when the caller gives no objects)."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # push_into_region: "half of the blocks", accepted within +-10 % of all blocks (paper: 16-24 of 40).
    "count": {
        "fraction": 0.5,
        "tolerance_fraction": 0.10,
        # Aim below the centre of the band: pushes in flight when the monitor halts the policy
        # still carry a few blocks in, so halting at the centre would drift toward the upper bound.
        "aim_below_centre": 0.5,  # fraction of the half-band
    },
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


@dataclass(frozen=True)
class SweepGoal:
    """The movable blocks and the target region object."""

    blocks: tuple[str, ...]
    region: str


def understand(ins: Instruction, objects: list[str]) -> SweepGoal | None:
    """The blocks and region grounded on ``objects``; None when the instruction is not about sweeping."""
    s = ins.lower
    if not (any(w in s for w in ("sweep", "push")) and any(w in s for w in ("zone", "area", "region", "half"))):
        return None
    names = [o for o in objects if "/" not in o]
    region = next((o for o in names if o in ("zone", "region", "area")), "")
    blocks = tuple(sorted(o for o in names if re.fullmatch(r"block_\d+", o)))
    return SweepGoal(blocks, region) if region and blocks else None


def scene(ins: Instruction) -> list[str] | None:
    """The sweep-half scene's objects, or None."""
    s = ins.lower
    if any(w in s for w in ("sweep", "push")) and any(w in s for w in ("zone", "area", "region", "half")):
        return [f"block_{i:02d}" for i in range(SWEEP_BLOCKS)] + ["zone", "table"]
    return None


def sweep_bounds(n_blocks: int) -> tuple[int, int, int, str]:
    """``(lower, upper, target, why)`` for "half of the blocks, within +-10 % of all blocks"."""
    thr = _thr("count")
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
        constraint(
            f"reached_half_in_{region}",
            f"at least {target} of the {len(blocks)} blocks are inside {nice(region)} (half, accepted {lower}-{upper})",
            "upon", False, thr, parts,
        ),
        constraint(
            f"capped_in_{region}",
            f"no more than {upper} blocks are inside {nice(region)}; more cannot be undone",
            "during", False, thr, parts,
        ),
    ]
    return cons, why


# --- templates ---------------------------------------------------------------------------------------------
def _blocks_and_zone(c: Spec) -> tuple[int, list[int]]:
    ids = c["element_ids"]
    zone = next(i for i, p in zip(ids, c["parts"]) if p["kind"] == "surface")
    return zone, [i for i, p in zip(ids, c["parts"]) if p["kind"] == "point"]


def reached(c: Spec) -> str:
    zone, blocks = _blocks_and_zone(c)
    th = c["thresholds"]
    tgt, total = int(th["target"]), len(blocks)
    body = f"""
    n = count_in_polygon([E[i] for i in {tuple(blocks)!r}], E[{zone}])
    if n >= {tgt}:
        return True, "%d of {total} blocks are inside the zone (target {tgt})" % n, n - {tgt} + 0.5
    return False, "only %d of {total} blocks are inside the zone (target {tgt})" % n, n - {tgt} + 0.5
"""
    return check_fn(c, body)


def capped(c: Spec) -> str:
    zone, blocks = _blocks_and_zone(c)
    up = int(c["thresholds"]["upper"])
    body = f"""
    n = count_in_polygon([E[i] for i in {tuple(blocks)!r}], E[{zone}])
    if n <= {up}:
        return True, "%d blocks are inside the zone (at most {up})" % n, {up} - n + 0.5
    return False, "%d blocks are inside the zone, more than {up}" % n, {up} - n + 0.5
"""
    return check_fn(c, body)


# --- the rule ----------------------------------------------------------------------------------------------
def next_sweep(task: SweepGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    cons, why = push_into_region(task.blocks, task.region)
    if previous and previous.get("action"):
        cat = classify(feedback)
        if cat == "success":
            return done("about half of the blocks are inside the zone")
        if cat == "overshoot":
            return done("more blocks than the accepted band are inside the zone and no skill can take them "
                         "out; stopping")
        why = f"the previous push did not reach the target ({cat}); keep pushing. " + why
    text = f"push blocks into {nice(task.region)} until about half of them are inside"
    return answer(text, "push_into_region", {"region": task.region}, cons, why)


FAMILY = TaskFamily(
    name="sweep",
    task="sweep-half",
    summary="push about half of the blocks into the marked zone",
    example="sweep half of the blocks into the zone",
    understand=understand,
    next_subgoal=next_sweep,
    scene=scene,
    thresholds=THRESHOLDS,
    templates={"reached": reached, "capped": capped},
    keywords=(("inside", "reached"),),
)
