
"""kb family ``sweep`` (task ``sweep-half``): push blocks into a marked region with the spatula until a count
asked for ("half of the blocks", "10 blocks", "all of them", "between 6 and 10") is inside.

Plan: one ``push_into_region`` subgoal; upon, the count inside the region reaches the target; during, it does not
exceed the accepted band (blocks pushed in cannot be taken out). Elements: the region's surface and every block
as a point. Recovery: keep pushing until the count is reached; past the band there is nothing to undo, stop.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction, Quantity
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice, whole
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn
from code_as_monitor.vlm.kb.shared.feedback import classify
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

SWEEP_BLOCKS = 40
"""Blocks in the simulator's sweep-half scene (used when the caller gives no objects)."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # push_into_region: a fraction asked for ("half of the blocks") is accepted within +-10 % of all blocks
    # (the paper's "half": 16-24 of 40); a plain count ("10 blocks") within +-10 % of itself.
    "count": {
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
    """The movable blocks, the target region object and how many blocks must end inside it.

    Attributes:
        lower, upper: the accepted count band (the task succeeds with ``lower`` to ``upper`` blocks inside).
        target: the count at which the monitor halts the pushing (see :func:`band`).
        asked: the quantity as the instruction put it ("half of the blocks", "10 blocks").
    """

    blocks: tuple[str, ...]
    region: str
    lower: int
    upper: int
    target: int
    asked: str = "half of the blocks"


VERBS = ("sweep", "push", "put", "slide", "drag")
DOING = "pushes blocks into the marked zone with the spatula until a count is inside"
REGION_NAMES = ("zone", "region", "area")


def band(n: int, q: Quantity | None, definite: bool) -> tuple[int, int, int]:
    """``(lower, upper, target)`` for a quantity of ``n`` blocks.

    A fraction, "all" or an approximate count ("half of the blocks", "all the blocks", "about 10 blocks") is
    accepted within +-10 % of all blocks (the paper's "half": 16-24 of 40), a plain count ("10 blocks") within
    +-10 % of itself (9-11), both clipped to 1..n; "exactly" accepts the count alone,
    "between 6 and 10" that range, "at least 10" / "more than 10" up to every block. The monitor halts at the
    centre when the band reaches every block (nothing can overshoot), else below the centre: pushes in flight
    when the policy stops still carry blocks in.

    Raises:
        ValueError: a quantity that asks for no reachable count (the message says why).
    """
    thr = _thr("count")
    tol = n * thr["tolerance_fraction"]
    if q is None:
        if not definite:
            raise ValueError("how many blocks? say a number, a fraction or all of them")
        q = Quantity("all", 1.0)
    if q.kind in ("some", "none"):
        raise ValueError(f"{q.text!r} is not a count to reach")
    if q.of_total is not None and q.of_total != n:
        raise ValueError(f"the scene has {n} blocks, not {q.of_total:g}")
    if q.kind == "number" and any(v is not None and v != int(v) for v in (q.value, q.high)):
        raise ValueError(f"{q.text!r}: a count of blocks is a whole number")
    value = n * q.value if q.kind in ("fraction", "all") else q.value
    high = q.high if q.high is not None else value
    if not 0 < value <= n or not value <= high <= n:
        raise ValueError(f"{q.text!r}: the scene has {n} blocks")
    if q.bound in ("at_most", "fewer"):
        raise ValueError(f"{q.text!r} sets a maximum but no count to reach")
    if q.bound == "exact":
        lo = hi = round(value)
    elif q.bound == "between":
        lo, hi = math.ceil(value), math.floor(high)
        value, tol = (value + high) / 2, (high - value) / 2
    elif q.bound in ("at_least", "more"):
        lo = math.floor(value) + 1 if q.bound == "more" else math.ceil(value)
        hi, value, tol = n, (lo + n) / 2, (n - lo) / 2
    else:
        if q.kind == "number" and q.bound == "plain":
            tol = thr["tolerance_fraction"] * value
        lo, hi = max(1, math.ceil(value - tol - 1e-9)), min(n, math.floor(value + tol + 1e-9))
    if not 1 <= lo <= hi <= n:
        raise ValueError(f"{q.text!r}: no count of the {n} blocks satisfies it")
    target = lo if q.bound in ("at_least", "more") else (
        round(value) if hi >= n else max(lo, round(value - thr["aim_below_centre"] * tol)))
    return lo, hi, min(hi, target)


def claims(ins: Instruction) -> bool:
    return "sweep" in ins.verbs or "zone" in ins.heads


def understand(ins: Instruction, objects: list[str]) -> SweepGoal | None:
    """The blocks, region and count grounded on ``objects``; None when the instruction is not about sweeping."""
    if not claims(ins):
        return None
    r = Reading(ins, "sweep-half", heads=("zone", "block"), verbs=VERBS)
    r.verbs(VERBS, DOING)
    r.modifiers((), DOING)
    names = scene_names(objects)
    region = next((o for o in names if o in REGION_NAMES), "")
    blocks = tuple(sorted(o for o in names if re.fullmatch(r"block_\d+", o)))
    zones = r.phrases(lambda p: p.head == "zone")
    # "half of the pile": the scene's pile is its blocks (the lexicon reads "pile" as a tower of blocks)
    movers = r.phrases(lambda p: p.head == "block" or (p.head in ("", "tower") and p.quantity is not None
                                                        and not p.colour))
    if not region or not blocks:
        r.refuse("the scene has no zone and blocks to sweep" if not region else "the scene has no blocks to sweep")
    if len(movers) != 1:
        r.refuse("say which blocks to push (e.g. 'half of the blocks')" if not movers else
                 "name the blocks to push once")
    for z in zones:
        zq = ins.resolve(z.index).quantity
        if zq is not None and not (zq.kind == "all" and zq.of_total is None):  # "the whole zone" is the zone
            r.refuse(f"{z.text!r}: the blocks go into the one zone, all of it")
        if ins.resolve(z.index).colour not in ("", "yellow"):
            r.refuse(f"there is no {ins.resolve(z.index).colour} zone (the zone is yellow)")
    mover = ins.resolve(movers[0].index)
    if mover.head == "block" and not mover.plural and mover.quantity is None:
        r.refuse(f"{movers[0].text!r}: which block? the scene has {len(blocks)}; say how many to push")
    if mover.colour:
        r.refuse(f"the blocks are not told apart by colour ({mover.colour!r})")
    into = r.links(("into", "on", "to", "at"), lambda p: p.head == "zone")
    if not zones or not into:
        r.refuse("say where to push the blocks: into the zone")
    for k in into:
        r.use_link(k)
    r.use(movers[0].index, *(z.index for z in zones))
    for k in r.links(("on", "from", "at"), lambda p: p.head == "table"):
        r.use_link(k)  # "the blocks on the table"
        r.use(k.b)
    for k in r.links(("in", "into", "on", "from", "of", "at"), lambda p: p.head == "tower" and p.quantity is None):
        r.use_link(k)  # "the blocks in the pile", "half the blocks from the pile": where they lie, not a goal
        r.use(k.b)
    try:
        lo, hi, target = band(len(blocks), mover.quantity, mover.definite or mover.pronoun != "")
    except ValueError as exc:
        r.refuse(str(exc))
    r.finish()
    return SweepGoal(blocks, region, lo, hi, target, mover.text)


def scene(ins: Instruction) -> list[str] | None:
    """The sweep-half scene's objects, or None."""
    return [f"block_{i:02d}" for i in range(SWEEP_BLOCKS)] + ["zone", "table"] if claims(ins) else None


def task_params(goal: SweepGoal) -> dict[str, object]:
    """The sweep-half task's goal parameters: the accepted count band."""
    return {"min_in_zone": goal.lower, "max_in_zone": goal.upper}


def push_into_region(goal: SweepGoal) -> tuple[list[dict[str, Any]], str]:
    """``push_into_region``: upon, the count inside the region reaches the target; during, not above the band."""
    blocks, region, lower, upper, target = goal.blocks, goal.region, goal.lower, goal.upper, goal.target
    label = "half" if goal.asked.startswith("half") else "target"
    zone = {"name": f"{region} surface", "obj": region, "part": "surface", "kind": "surface"}
    parts = [zone] + [whole(b) for b in blocks]
    thr = {"target": float(target), "lower": float(lower), "upper": float(upper), "total": float(len(blocks))}
    why = (f"{goal.asked} of {len(blocks)}: accepted {lower}-{upper}; the monitor halts at {target}"
           + (", below the centre, because pushes in flight when the policy stops still carry blocks into the zone"
              if target < (lower + upper) / 2 else ""))
    cons = [
        constraint(
            f"reached_{label}_in_{region}",
            f"at least {target} of the {len(blocks)} blocks are inside {nice(region)} ({goal.asked}, accepted "
            f"{lower}-{upper})",
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
    cons, why = push_into_region(task)
    if previous and previous.get("action"):
        cat = classify(feedback)
        if cat == "success":
            return done(f"{task.asked} ({task.lower}-{task.upper}) are inside the zone")
        if cat == "overshoot":
            return done("more blocks than the accepted band are inside the zone and no skill can take them "
                         "out; stopping")
        why = f"the previous push did not reach the target ({cat}); keep pushing. " + why
    text = f"push blocks into {nice(task.region)} until {task.target} of them are inside ({task.asked})"
    return answer(text, "push_into_region", {"region": task.region}, cons, why)


FAMILY = TaskFamily(
    name="sweep",
    task="sweep-half",
    summary="push a count of the blocks (half, 10, all, ...) into the marked zone",
    example="sweep half of the blocks into the zone",
    understand=understand,
    next_subgoal=next_sweep,
    scene=scene,
    task_params=task_params,
    thresholds=THRESHOLDS,
    templates={"reached": reached, "capped": capped},
    keywords=(("inside", "reached"),),
)
