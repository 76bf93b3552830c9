# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``rope`` (task ``rope-close-square``): drag a rope across the opening of a square outline.

Plan: one ``close_shape`` subgoal; upon, resting rope beads lie along (nearly) all of the opening between
``corner_3`` and ``corner_0`` for a short while. Elements: the two corners of the opening and every rope bead
(``rope/bead_NN``, points). Recovery: keep adjusting the rope until the opening is enclosed.

How much of the opening: "enclosed" (the simulator's definition, ``rope_cover``: 90 % of 11 samples) unless the
instruction gives a fraction of the opening ("close half of the opening", "at least 80 % of the opening",
"100 % of the opening"), from ``MIN_COVERAGE`` to 1; "the whole opening", "fully", "completely" are the default
(enclosed). The fraction is the task's ``min_coverage`` (its success check follows it) and the check's
``min_fraction``. Upper limits ("at most half", "exactly 60 %") are refused: the rope is laid along the whole
opening and the check reads coverage from below.

What is read as closing the opening: a close verb ("close", "seal", "cover", "fill", "block", "enclose")
whose object is the opening or the square, or the rope put / dragged / laid across, along, over, into or to the
opening. The rope put into or onto the square (not its opening) is refused: that is another goal.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction, Phrase
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, num
from code_as_monitor.vlm.kb.shared.feedback import classify
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

DEFAULT_ROPE_BEADS = 20
"""Bead count assumed for ``rope`` when the scene does not list its parts (``rope/bead_NN``)."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # close_shape: the rope lies along the opening (enclosed, not a perfect square): at least
    # `min_fraction` of `samples` points spread along the opening, both corners included, have a
    # resting bead within `max_gap` horizontally (a gap narrower than a 2.5 cm block cannot let
    # anything through); beads above `max_z` (two bead radii plus 1 cm) are being carried, not resting.
    # The same definition as the simulator's "enclosed" (11 samples, 90 %, 2.5 cm), and it must have
    # held over the last `stable_s` seconds: a rope still being dragged encloses the opening for an
    # instant and opens again, so a halt on one frame stops the robot in a state that does not last.
    # `margin`: a sample counts as covered only within `max_gap - margin`, because the elements are
    # estimates: 3 mm, the point accuracy the perception is held to (issue #12's median target; on the
    # rope, beads are painted 1.9 mm median off their centres, and `depth` tracked them 1.3 mm median,
    # 3.5 mm p90, identity-free, in one probed episode). It was 6 mm (for the 8 mm worst case the
    # element target allows), which read most enclosed ropes as open: the policy lays the beads 15 mm
    # outside the opening, 15.0-16.6 mm from its samples, leaving 2.4-4.0 mm of a 19 mm reach for a bead
    # that settles or is read a little outward (in three probed episodes, of the 183-238 frames the task
    # called enclosed only 37-59 were so at 19 mm even from the true beads). The price: a rope halted at
    # the task's own borderline (91 %) may still relax open after the halt.
    "rope_cover": {"max_gap": 0.025, "margin": 0.003, "samples": 11, "min_fraction": 0.9, "max_z": 0.026,
                   "stable_s": 0.3},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


MIN_COVERAGE = 0.25
"""The smallest fraction of the opening the kb plans to cover (below it a rope lying near one corner would do)."""


@dataclass(frozen=True)
class RopeGoal:
    """The rope, the shape whose opening it closes, the rope's bead parts in order (ends first and last), and
    the fraction of the opening that must be covered (``None``: enclosed, the default)."""

    rope: str
    shape: str
    rope_beads: tuple[str, ...]
    coverage: float | None = None


VERBS = ("use", "close", "fill", "put", "drag", "arrange", "pull", "pick", "grasp")
CLOSING = ("close", "fill")
"""Verbs whose object may be the opening or the square itself ("close the square", "seal the gap")."""
PLACING = ("into", "on", "across", "along", "above", "to", "in_front_of", "through")
"""Links from the rope (or the verb) to the opening that place the rope across it."""
DOING = "drags the rope across the opening of the square outline until the opening is closed"
HEADS = ("rope", "opening", "square")


def claims(ins: Instruction) -> bool:
    return bool({"rope", "opening"} & ins.heads) or ("square" in ins.heads and "close" in ins.verbs)


def scene_parts(objects: list[str]) -> dict[str, list[str]]:
    """Parts listed in the scene as ``"obj/part"`` entries, by object."""
    parts: dict[str, list[str]] = {}
    for o in objects:
        if "/" in o:
            obj, part = o.split("/", 1)
            parts.setdefault(obj, []).append(part)
    return parts


def understand(ins: Instruction, objects: list[str]) -> RopeGoal | None:
    """The rope, shape and beads grounded on ``objects``; None when the instruction is not about the rope."""
    if not claims(ins):
        return None
    r = Reading(ins, "rope-close-square", heads=HEADS, verbs=VERBS)
    r.verbs(VERBS, DOING, once=True)
    r.modifiers(("fully",), DOING)
    ropes = r.phrases(lambda p: p.head == "rope")
    targets = r.phrases(lambda p: p.head in ("opening", "square"))
    if not ropes:
        r.refuse("what closes the opening? the kb's rule uses the rope")
    if not targets:
        r.refuse("say what the rope should close: the opening of the square")
    if len({ins.resolve(p.index).index for p in ropes}) > 1:
        r.refuse("the scene has one rope: name it once")
    coverage: float | None = None
    for p in ropes + targets:
        q = ins.resolve(p.index)
        if q.head == "opening" and q.quantity is not None and q.quantity.kind in ("fraction", "all") \
                and not q.colour and not q.position and not q.ordinal and coverage is None:
            coverage = _coverage(r, q)
        elif q.colour or q.quantity is not None or q.position or q.ordinal:
            r.refuse(f"{p.text!r}: the scene has one rope and one square")
        r.use(p.index)
    placed = False
    for k in ins.links:
        a = ins.resolve(k.a).head if k.a is not None else ""
        b = ins.resolve(k.b).head
        if k.kind in PLACING and b == "opening" and a in ("", "rope"):
            r.use_link(k)
            placed = True
        elif (k.kind in ("of", "into", "on") and a == "opening" and b == "square") or (
                k.kind == "with" and b == "rope"):
            r.use_link(k)
    closing = set(CLOSING) & set(ins.verbs)
    if not closing and not placed:
        r.refuse("say where the rope goes: across the opening of the square (or 'close the opening with the rope')")
    if not closing and not any(ins.resolve(p.index).head == "opening" for p in targets):
        r.refuse("the rope closes the square's opening; say 'the opening'")
    names = scene_names(objects)
    rope = next((o for o in names if "rope" in o), "")
    shape = next((o for o in names if o in ("square", "shape", "outline")), "")
    if not rope or not shape:
        r.refuse("the scene has no rope" if not rope else "the scene has no square outline")
    r.finish()
    beads = sorted(p for p in scene_parts(objects).get(rope, []) if re.fullmatch(r"bead_\d+", p))
    if not beads:
        beads = [f"bead_{i:02d}" for i in range(DEFAULT_ROPE_BEADS)]
    return RopeGoal(rope, shape, tuple(beads), coverage)


def _coverage(r: Reading, q: Phrase) -> float | None:
    """The fraction of the opening asked for by ``q``'s quantity; None for "the whole opening" (enclosed)."""
    qty = q.quantity
    assert qty is not None
    if qty.kind == "all":
        return None
    if qty.bound not in ("plain", "about", "at_least", "more") or qty.of_total is not None:
        r.refuse(f"cannot promise {q.text!r}: the rope is laid along all of it and the "
                 f"check reads how much it covers from below (say e.g. 'at least 80 % of the opening')")
    if not MIN_COVERAGE - 1e-9 <= qty.value <= 1.0 + 1e-9:
        r.refuse(f"cannot cover {q.text!r}: the kb covers {MIN_COVERAGE * 100:.0f} to "
                 f"100 % of it")
    return round(float(qty.value), 4)

def scene(ins: Instruction) -> list[str] | None:
    """The rope-close-square scene's objects, or None."""
    return ["rope", "square", "table"] if claims(ins) else None


def task_params(goal: RopeGoal) -> dict[str, object]:
    """The rope-close-square task's goal parameter: the fraction of the opening to cover ({} for enclosed)."""
    return {} if goal.coverage is None else {"min_coverage": goal.coverage}


def close_shape(rope: str, shape: str, beads: tuple[str, ...], coverage: float | None = None) -> list[dict[str, Any]]:
    """``close_shape``: upon, resting rope beads lie along (nearly) all of the opening between corner_3 and corner_0
    (``coverage`` of it when given)."""
    thr = _thr("rope_cover")
    if coverage is not None:
        thr["min_fraction"] = coverage
    parts = [
        {"name": f"{shape} opening corner_0", "obj": shape, "part": "corner_0", "kind": "point"},
        {"name": f"{shape} opening corner_3", "obj": shape, "part": "corner_3", "kind": "point"},
    ] + [{"name": f"rope {b}", "obj": rope, "part": b, "kind": "point"} for b in beads]
    return [
        {**constraint(
            "rope_covers_opening",
            f"{nice(rope)} closes the opening of {nice(shape)}: at least {thr['min_fraction'] * 100:.0f} % of "
            f"the opening (corner_3 to corner_0, corners included) has a resting rope bead within "
            f"{thr['max_gap'] * 100:.1f} cm, steadily for {thr['stable_s']:g} s (judged within "
            f"{(thr['max_gap'] - thr['margin']) * 100:.1f} cm: the elements are estimates)",
            "upon", False, thr, parts,
        ), "monotone": [rope]}  # any bead covers a sample: a bead unseen this frame can only add coverage
    ]


# --- templates ---------------------------------------------------------------------------------------------
def covers(c: Spec) -> str:
    c0, c3 = c["element_ids"][:2]
    beads = tuple(c["element_ids"][2:])
    # the beads are monotone members (``Constraint.monotone``): the agent may leave unseen ones out of E and H
    seen = bool(set(beads) & set(c.get("monotone") or ()))
    th = c["thresholds"]
    gap = num(th["max_gap"] - th.get("margin", 0.0))
    n, mz, frac = int(th["samples"]), num(th["max_z"]), num(th["min_fraction"])
    win = num(th["stable_s"])
    if seen:  # the beads seen this frame (an empty set covers nothing: the minimum starts at 1 m)
        pick = f"present = [i for i in {beads!r} if i in H]\n    "
        each, least = "present", "np.min(d, axis=1, initial=1.0)"
        count = f" (%d of {len(beads)} beads seen)\" % (100 * covered, len(present))"
    else:
        pick, each, least, count = "", repr(beads), "np.min(d, axis=1)", "\" % (100 * covered)"
    body = f"""
    {pick}s = np.linspace(0.0, 1.0, {n})
    covered = 1.0
    for j in np.nonzero(H.t >= t - {win})[0]:
        a = centroid(H[{c0}][j])
        b = centroid(H[{c3}][j])
        samples = a[None, :2] + s[:, None] * (b - a)[None, :2]
        beads = np.array([centroid(H[i][j]) for i in {each}]).reshape(-1, 3)
        carried = np.maximum(beads[:, 2] - {mz}, 0.0) * 1000.0
        d = np.sqrt(np.sum((samples[:, None, :] - beads[None, :, :2]) ** 2, axis=2)) + carried[None, :]
        covered = min(covered, float(np.mean({least} <= {gap})))
    if covered >= {frac}:
        return True, "the rope has closed the opening for {win} s (at least %.0f%% of it within {gap} m of a resting bead){count}, covered - {frac} + 0.5 / {n}
    return False, "the opening of the square is not enclosed steadily: over the last {win} s as little as %.0f%% of it was within {gap} m of a resting rope bead{count}, covered - {frac} + 0.5 / {n}
"""
    return check_fn(c, body)


# --- the rule ----------------------------------------------------------------------------------------------
def next_rope(task: RopeGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    why = "the opening lies between corner_3 and corner_0; it is enclosed when rope beads lie all along it"
    if previous and previous.get("action"):
        cat = classify(feedback)
        if cat == "success":
            return done("the opening of the square is enclosed by the rope")
        why = f"the opening is not enclosed yet ({cat}); keep adjusting the rope. " + why
    cons = close_shape(task.rope, task.shape, task.rope_beads, task.coverage)
    text = f"close the opening of {nice(task.shape)} with {nice(task.rope)}"
    return answer(text, "close_shape", {"rope": task.rope, "shape": task.shape}, cons, why)


FAMILY = TaskFamily(
    name="rope",
    task="rope-close-square",
    summary="close the opening of the square outline with the rope (all of it or a fraction asked for)",
    example="use the rope to close the opening of the square",
    understand=understand,
    next_subgoal=next_rope,
    scene=scene,
    task_params=task_params,
    thresholds=THRESHOLDS,
    templates={"rope": covers},
    keywords=(("rope", "rope"),),
)
