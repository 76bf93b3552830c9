"""The stack family's reading of an instruction: which blocks go in the tower, and in what order.

What it reads (from :mod:`code_as_monitor.vlm.grammar`):

- block references: a colour ("red", "the red block", "the red one", "it") grounded on the scene's
  ``<colour>_block`` objects; a collective ("the blocks", "all three blocks", "a tower") means every block;
- relations: "X on (top of) / onto Y" (X directly on Y), "X under / beneath Y" (Y directly on X),
  "X above / below Y" (higher / lower, not necessarily adjacent), "X on the table" (X at the bottom);
- positions: "at the bottom", "in the middle", "on top", "the second ... from the top";
- listings: "red, green and blue", "red at the bottom, then green, then blue", read bottom first unless
  the listing says otherwise ("from top to bottom", its first item "on top", its last "at the bottom").
  A bare listing is read bottom first, the order a tower is built in. A listing whose items carry their
  own positions ("green at the bottom and blue on top") is read by the positions alone.

The order is whatever satisfies all of these (:mod:`code_as_monitor.vlm.kb.shared.order`): exactly one order
plans; none is a contradiction, several an order left open (refused, naming the blocks), except when the
instruction says nothing about the order at all ("stack the blocks"): then any order is asked for, the kb
builds the scene's order and the task accepts any.
"""

from __future__ import annotations

from dataclasses import dataclass

from code_as_monitor.vlm.grammar import Instruction, Phrase
from code_as_monitor.vlm.kb.shared.order import OrderConstraints, solve, undetermined
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

TASK = "stack-in-order"
VERBS = ("stack", "build", "put", "pick", "grasp", "arrange", "drop")
MODIFIERS = ("in_order", "in_tower", "together", "neat", "any_order", "up")
DOING = "stacks coloured blocks into a tower with the suction cup"
BLOCKISH = ("", "block", "one")


@dataclass(frozen=True)
class StackGoal:
    """The tower to build: block names, bottom first; ``any_order``: the instruction left the order open."""

    tower: tuple[str, ...]
    any_order: bool = False


def _colour_block(colour: str, names: list[str]) -> str | None:
    return next((o for o in names if o.lower() == colour or o.lower().startswith(f"{colour}_")), None)


def scene_blocks(objects: list[str]) -> list[str]:
    """The scene's stackable blocks (``<colour>_block``), in scene order."""
    return [o for o in scene_names(objects) if o.endswith("_block")]


def claims(ins: Instruction) -> bool:
    """Is the instruction about stacking blocks?"""
    heads = {ins.resolve(p.index).head for p in ins.phrases}
    coloured = any(ins.resolve(p.index).colour and ins.resolve(p.index).head in BLOCKISH for p in ins.phrases)
    return bool({"stack", "build"} & set(ins.verbs) or {"tower", "block"} & heads or coloured)


def _ordinal_level(r: Reading, p: Phrase) -> int:
    if p.ordinal == -1:
        return -1 if p.ordinal_from != "bottom" else 0
    if not p.ordinal_from:
        r.refuse(f"{p.text!r}: say from the bottom or from the top")
    return p.ordinal - 1 if p.ordinal_from == "bottom" else -p.ordinal


def understand(ins: Instruction, objects: list[str]) -> StackGoal | None:
    """The tower asked for, grounded on ``objects``; None when the instruction is not about stacking."""
    if not claims(ins):
        return None
    r = Reading(ins, TASK, heads=("block", "tower", "table"), verbs=VERBS)
    r.verbs(VERBS, DOING)
    r.modifiers(MODIFIERS, DOING)
    blocks = scene_blocks(objects)
    shown = ", ".join(blocks) or "none"
    refs: dict[int, str] = {}  # phrase index -> block name
    everything = members_named = False
    count: float | None = None
    for p in ins.phrases:
        q = ins.resolve(p.index)
        if q.head == "table":
            if q.role != "complement":
                r.refuse("the table is not a block to stack")
            continue  # used by its link
        if q.colour and q.head in BLOCKISH:
            name = _colour_block(q.colour, blocks)
            if name is None:
                r.refuse(f"there is no {q.colour} block in the scene (blocks: {shown})")
            if q.quantity is not None and q.quantity.value != 1:
                r.refuse(f"{p.text!r}: there is one {q.colour} block")
            refs[p.index] = name
        elif q.head in ("block", "tower") and not q.colour:
            if q.position or q.ordinal:
                r.refuse(f"{p.text!r}: which block? name it by its colour")
            if q.head == "block" and not (q.plural or q.quantity):
                r.refuse(f"{p.text!r}: which block? name it by its colour")
            if q.quantity is not None and q.head == "tower":  # "into a single tower", "one tower": the one it builds
                if q.quantity.kind != "number" or q.quantity.value != 1 or q.quantity.bound not in ("plain", "exact"):
                    r.refuse(f"{q.quantity.text!r}: the kb builds one tower")
            elif q.quantity is not None:
                if q.quantity.kind not in ("number", "all") or q.quantity.bound not in ("plain", "exact"):
                    r.refuse(f"{q.quantity.text!r}: say which blocks")
                count = len(blocks) if q.quantity.kind == "all" and q.quantity.of_total is None else (
                    q.quantity.of_total if q.quantity.kind == "all" else q.quantity.value)
            everything = True
        else:
            r.refuse(f"has no use for {p.text!r}")
        r.use(p.index)
    c = OrderConstraints(items=[])
    for k in ins.links:
        a = refs.get(k.a) if k.a is not None else None
        b = refs.get(k.b)
        tb = ins.resolve(k.b).head == "table"
        if k.kind == "on" and a and tb:
            c.at.append((a, 0))
        elif k.kind in ("on", "under", "above", "below") and a and b:
            if a == b:
                r.refuse(f"{ins.phrases[k.a].text!r} cannot go {k.kind} itself")  # type: ignore[index]
            {"on": c.on, "under": c.on, "above": c.above, "below": c.above}[k.kind].append(
                (a, b) if k.kind in ("on", "above") else (b, a))
        elif k.kind in ("with", "of") and k.a is not None and ins.resolve(k.a).head in ("tower", "block") and (
                b or ins.resolve(k.b).head == "block"):
            members_named = members_named or (k.kind == "of" and b is not None)  # "a tower of the red and green ..."
        else:
            continue  # left unused: finish() names it
        r.use_link(k)
    for i, name in refs.items():
        p = ins.resolve(i)
        if p.position in ("bottom", "table"):
            c.at.append((name, 0))
        elif p.position in ("top", "middle"):
            c.at.append((name, -1 if p.position == "top" else "middle"))
        if p.ordinal:
            c.at.append((name, _ordinal_level(r, p)))
    _listings(ins, r, refs, c)
    named = list(dict.fromkeys(refs[i] for i in sorted(refs)))
    if count is not None and count not in (len(blocks), len(named)):
        r.refuse(f"{count:g} blocks: the scene has {len(blocks)} ({shown}) and the instruction names {len(named)}")
    members = blocks if everything and not members_named and count in (None, len(blocks)) else named
    c.items = [b for b in blocks if b in members]
    if len(c.items) < 2:
        r.refuse(f"a tower needs at least two blocks (named: {', '.join(named) or 'none'})")
    r.finish()
    if "any_order" in ins.modifiers:
        if not c.empty():
            r.refuse("'in any order' contradicts the order it gives")
        return StackGoal(tuple(c.items), any_order=True)
    if c.empty():
        return StackGoal(tuple(c.items), any_order=True)
    orders = solve(c)
    if not orders:
        r.refuse("the order asked for is contradictory")
    if len(orders) > 1:
        r.refuse(f"the order of {', '.join(undetermined(orders))} is not given")
    return StackGoal(orders[0])


def _listings(ins: Instruction, r: Reading, refs: dict[int, str], c: OrderConstraints) -> None:
    """Listed blocks are consecutive, bottom first unless the listing or the instruction says top first."""
    dirs = set(ins.directions)
    if len(dirs) > 1:
        r.refuse("the instruction reads both from the bottom and from the top")
    for lst in ins.listings:
        items = [i for i in lst.items if i in refs]
        again = next((k for k in range(1, len(items)) if refs[items[k]] in {refs[i] for i in items[:k]}), None)
        if again is not None:  # "red and green, red at the bottom": the block named again is not a new member
            items = items[:again]
        if len(items) < 2 or sum(bool(ins.resolve(i).position) for i in items) > 1:
            continue  # "green at the bottom and blue on top": the positions say it, not the listing
        # where the first or last member sits, said with it or with its mention again ("..., blue at the bottom")
        where = {refs[i]: ins.resolve(i).position for i in lst.items if i in refs and ins.resolve(i).position}
        first, last = where.get(refs[items[0]]), where.get(refs[items[-1]])
        down = "down" in dirs or first == "top" or last in ("bottom", "table")
        seq = [refs[i] for i in items]
        c.sequences.append(seq[::-1] if down else seq)
        r.used_directions = True
    if dirs and not c.sequences:
        r.used_directions = False


SIM_BLOCKS = ("red_block", "green_block", "blue_block")
"""The simulator's stack-in-order blocks."""


def scene(ins: Instruction) -> list[str] | None:
    """The simulator's stack-in-order scene (its three blocks and the table); None when not about stacking."""
    return [*SIM_BLOCKS, "table"] if claims(ins) else None


def task_params(goal: StackGoal) -> dict[str, object]:
    """The stack-in-order task's goal parameters."""
    return {"order": list(goal.tower), "any_order": goal.any_order}
