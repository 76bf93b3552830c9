"""Reading the task from the instruction and the scene's object list (rule-based, no learning)."""

from __future__ import annotations

import re
from dataclasses import dataclass

COLOURS = ("red", "green", "blue", "yellow", "orange", "purple", "pink", "white", "black", "brown", "gray", "cyan")
SWEEP_BLOCKS = 40


@dataclass(frozen=True)
class TaskSpec:
    """What the kb understood: the task family and its grounded objects.

    Attributes:
        family: "stack", "sweep" or "rope".
        tower: for "stack", the block names bottom first.
        blocks: for "sweep", the movable blocks.
        region: for "sweep", the target region object.
        rope, shape: for "rope".
        rope_beads: for "rope", its bead parts in order (first and last are the ends).
    """

    family: str
    tower: tuple[str, ...] = ()
    blocks: tuple[str, ...] = ()
    region: str = ""
    rope: str = ""
    shape: str = ""
    rope_beads: tuple[str, ...] = ()


def family_of(instruction: str) -> str | None:
    """The task family an instruction names, or None."""
    s = instruction.lower()
    if "rope" in s and any(w in s for w in ("close", "enclose", "opening", "square")):
        return "rope"
    if any(w in s for w in ("sweep", "push")) and any(w in s for w in ("zone", "area", "region", "half")):
        return "sweep"
    if "stack" in s or "tower" in s:
        return "stack"
    return None


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


def scene_parts(objects: list[str]) -> dict[str, list[str]]:
    """Parts listed in the scene as ``"obj/part"`` entries, by object."""
    parts: dict[str, list[str]] = {}
    for o in objects:
        if "/" in o:
            obj, part = o.split("/", 1)
            parts.setdefault(obj, []).append(part)
    return parts


def understand(instruction: str, objects: list[str], rope_beads: int) -> TaskSpec | None:
    """Ground ``instruction`` on ``objects``; None when the kb has no rule for it."""
    fam = family_of(instruction)
    names = [o for o in objects if "/" not in o]
    if fam == "stack":
        tower = tower_order(instruction, names)
        return TaskSpec("stack", tower=tower) if len(tower) >= 2 else None
    if fam == "sweep":
        region = next((o for o in names if o in ("zone", "region", "area")), "")
        blocks = tuple(sorted(o for o in names if re.fullmatch(r"block_\d+", o)))
        return TaskSpec("sweep", blocks=blocks, region=region) if region and blocks else None
    if fam == "rope":
        rope = next((o for o in names if "rope" in o), "")
        shape = next((o for o in names if o in ("square", "shape", "outline")), "")
        if not rope or not shape:
            return None
        beads = sorted(p for p in scene_parts(objects).get(rope, []) if re.fullmatch(r"bead_\d+", p))
        if not beads:
            beads = [f"bead_{i:02d}" for i in range(rope_beads)]
        return TaskSpec("rope", rope=rope, shape=shape, rope_beads=tuple(beads))
    return None


def infer_objects(instruction: str) -> list[str]:
    """The simulator's object list for an instruction (used when the caller gives none)."""
    from code_as_monitor.vlm.kb.manip import infer_objects as manip_objects

    gripper_task = manip_objects(instruction)
    if gripper_task is not None:
        return gripper_task
    fam = family_of(instruction)
    if fam == "sweep":
        return [f"block_{i:02d}" for i in range(SWEEP_BLOCKS)] + ["zone", "table"]
    if fam == "rope":
        return ["rope", "square", "table"]
    s = instruction.lower()
    colours = [c for _, c in sorted((s.find(c), c) for c in COLOURS if re.search(rf"\b{c}\b", s))]
    return [f"{c}_block" for c in colours] + ["table"]
