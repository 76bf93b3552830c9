# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``bulb`` (task ``screw-bulb``): screw the light bulb into its socket.

Plan: ``grasp`` the lamp's bulb (jaws across the ball) -> ``screw`` it one turn (the skill turns it in strokes,
letting go and grasping again between them, and lets go at the end) -> done.

Elements, all points: the grasp point (``robot/tip``), the bulb (``lamp/bulb``), the socket (``lamp/socket``), the
gripper's jaws (``robot/finger_left``, ``robot/finger_right``; proprioception, their distance is the jaw opening).
A screwed bulb goes down: the thread lowers it ``THREAD_DROP`` per turn (``sim/tasks/screw_bulb.py``: 1.5 cm), so
how far it turned is read from how high its centre stands above the socket's (its turn itself is invisible on a
round ball). Not from how far it came down since the screw began: ``H`` holds the last 64 frames (6.4 s at 10 Hz)
and three strokes take about 9 s, so the oldest frame is not the screw's start.

Recovery by the failed constraint's id prefix:

=========================================== ==================================================
failed                                      next subgoal
=========================================== ==================================================
bulbgrip, bulbjaw (not held)                grasp the bulb again
bulbseated, screwed (not down far enough)    grasp the bulb again, then screw again
freed (still held after the screw)          screw again (it ends by letting go)
=========================================== ==================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name
from code_as_monitor.vlm.kb.shared.feedback import failed_kind
from code_as_monitor.vlm.kb.shared.grip import FINGER_LEFT, FINGER_RIGHT, GRIP_TIP, part_spec
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

THREAD_DROP = 0.015
"""Metres a bulb goes down per turn in this lamp's socket (its thread's pitch; ``sim/assets/lamp.urdf``)."""
TURNS = 1.0
"""Turns to screw the bulb in (it stands one turn out of its socket)."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # grasp, upon: the bulb's centre within 4 cm of the grasp point: the jaws close on a 5 cm ball anywhere within
    # its 2.5 cm radius, and its painted centre (from its visible half) sits up to 1.5 cm off its true centre (at
    # 3 cm a held bulb was flagged at 3.1 cm in the benchmark). A grasp that misses the ball closes the jaws on
    # nothing, which ``bulbjaw`` sees.
    "bulbgrip": {"max_dist": 0.04},
    # grasp, upon: the jaws closed on the ball: 3 to 7.5 cm apart (on the 5 cm ball 5 cm plus the pads, 1 cm a
    # side: 7 cm; closed on nothing 0; open 8 cm: the upper bound halfway between held and open).
    "bulbjaw": {"min_jaw": 0.03, "max_jaw": 0.075},
    # screw, during: the bulb stays on its socket: within 2 cm of the socket sideways (it is on its thread)
    # and not more than 1 cm higher than when the screw began (it only goes down as it turns in).
    "bulbseated": {"max_off": 0.02, "max_rise": 0.01},
    # screw, upon: the bulb's centre at most 3.9 cm above the socket's. Seated, the ball's centre is 3.7 cm above
    # the socket's (socket z 6-9 cm, ball centre 2.2 cm above the bulb's bottom at the mouth); painted from its
    # visible pixels (the neck pulls it down) the points stand 3.0-3.3 cm apart seated and 4.5-4.6 cm with the
    # bulb 1.5 cm out (measured on the sim segmenter's paintings, seeds 0-2, at bb19bf5): the bound is about halfway,
    # the bulb within ~7 mm (half a turn) of seated. That holds for the bulb painted out of the socket and tracked
    # down; today's painter, painting the seated bulb afresh (its neck inside the socket), reads 38-48 mm (seeds 0, 1,
    # 2, 21, every view set), so the screw's end judges a tracked bulb where tracked (agent.completion._carried_away).
    "screwed": {"max_above": 0.039},
    # screw, upon: released: the grasp point 5 cm from the bulb's centre (the ball's 2.5 cm radius plus the
    # fingers' clearance).
    "bulb_freed": {"release_dist": 0.05},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


@dataclass(frozen=True)
class BulbGoal:
    """The lamp whose bulb is to be screwed in."""

    lamp: str


VERBS = ("screw", "turn", "grasp")
STEPS = ("put", "insert", "pick")
"""Verbs read as steps of the screwing when "screw" is said too (alone, "put the bulb in the lamp" is refused)."""
MODIFIERS = ("in", "fully", "down")
HEADS = ("bulb", "lamp", "socket")
DOING = "screws the light bulb into its socket (about one turn)"


def claims(ins: Instruction) -> bool:
    return bool({"bulb", "lamp"} & ins.heads)


def understand(ins: Instruction, objects: list[str]) -> BulbGoal | None:
    """The lamp grounded on ``objects``; None when the instruction is not about a bulb."""
    if not claims(ins):
        return None
    # "put the bulb in its socket and screw it in": putting or picking it up is part of the screwing, said with it
    verbs = VERBS + (STEPS if "screw" in ins.verbs else ())
    r = Reading(ins, "screw-bulb", heads=HEADS, verbs=verbs)
    r.verbs(verbs, DOING)
    r.modifiers(MODIFIERS, DOING)
    if "screw" not in ins.verbs and not ("turn" in ins.verbs and "in" in ins.modifiers):
        r.refuse("say what to do with the bulb: screw it in")
    if "screw" in ins.verbs and "turn" in ins.verbs:  # "screw the bulb in 2 turns": the grammar reads "turns" as a verb
        r.refuse("cannot honour a number of turns: the kb screws the bulb in until it sits in its socket")
    for p in r.phrases(lambda p: p.head in HEADS):
        q = ins.resolve(p.index)
        if q.position or q.ordinal or (q.quantity is not None and q.quantity.value != 1):
            r.refuse(f"{p.text!r}: the scene has one lamp with one bulb")
        if q.colour and q.colour != "red":
            r.refuse(f"{p.text!r}: the scene's bulb is red")
        r.use(p.index)
    for k in ins.links:
        a = ins.resolve(k.a).head if k.a is not None else ""
        b = ins.resolve(k.b).head
        if (k.kind in ("into", "to", "on") and b in ("socket", "lamp")) or (k.kind == "of" and a == "bulb"):
            r.use_link(k)
        elif k.a is None and k.kind == "into" and k.words == "in" and b == "bulb":
            r.use_link(k)  # "screw in the bulb": the particle "in" before the object
    lamp = next((o for o in scene_names(objects) if "lamp" in o), "")
    if not lamp:
        r.refuse("the scene has no lamp")
    r.finish()
    return BulbGoal(lamp)


def scene(ins: Instruction) -> list[str] | None:
    """The screw-bulb scene's objects, or None."""
    return ["lamp", "table"] if claims(ins) else None


# --- constraint builders -----------------------------------------------------------------------------------
def _bulb(lamp: str) -> dict[str, str]:
    return part_spec(lamp, "bulb", "point", "bulb")


def _socket(lamp: str) -> dict[str, str]:
    return part_spec(lamp, "socket", "point", "socket")


def grasp(lamp: str) -> list[dict[str, Any]]:
    """``grasp`` the bulb: upon, it is at the grasp point and the jaws are closed on it."""
    gr, jw = _thr("bulbgrip"), _thr("bulbjaw")
    return [
        constraint(f"bulbgrip_{lamp}", f"the bulb of {nice(lamp)} is between the fingers: its centre within "
                   f"{gr['max_dist'] * 100:.0f} cm of the grasp point", "upon", False, gr, [GRIP_TIP, _bulb(lamp)]),
        constraint(f"bulbjaw_{lamp}", f"the gripper's jaws are closed on the bulb of {nice(lamp)}: their opening between "
                   f"{jw['min_jaw'] * 100:.0f} and {jw['max_jaw'] * 100:.0f} cm", "upon", False, jw,
                   [FINGER_LEFT, FINGER_RIGHT]),
    ]


def screw(lamp: str) -> list[dict[str, Any]]:
    """``screw``: during, the bulb stays seated on its socket; upon, it came down by most of a turn's thread and
    is released."""
    se, sc, fr = _thr("bulbseated"), _thr("screwed"), _thr("bulb_freed")
    return [
        constraint(f"bulbseated_{lamp}", f"the bulb of {nice(lamp)} stays on its socket (within {se['max_off'] * 100:.0f} cm "
                   f"of it sideways, never more than {se['max_rise'] * 100:.0f} cm higher than when the screw began)",
                   "during", False, se, [_bulb(lamp), _socket(lamp)]),
        constraint(f"screwed_{lamp}", f"the bulb of {nice(lamp)} is screwed in: its centre at most "
                   f"{sc['max_above'] * 100:.1f} cm above the socket's (the thread lowers it "
                   f"{THREAD_DROP * 100:.1f} cm per turn)", "upon", False, sc, [_bulb(lamp), _socket(lamp)]),
        constraint(f"freed_{lamp}", f"the bulb of {nice(lamp)} is released: the grasp point at least "
                   f"{fr['release_dist'] * 100:.0f} cm from it", "upon", False, fr, [GRIP_TIP, _bulb(lamp)]),
    ]


# --- templates ---------------------------------------------------------------------------------------------
def bulbgrip(c: Spec) -> str:
    """Parts: [tip (point), bulb (point)]. The bulb's centre is at the grasp point."""
    tip, b = c["element_ids"][:2]
    md, bn = num(c["thresholds"]["max_dist"]), obj_name(c, 1)
    body = f"""
    d = distance(E[{tip}], centroid(E[{b}]))
    if d <= {md}:
        return True, {lit("the bulb of " + bn + " is between the fingers (%.3f m from the grasp point)")} % d, {md} - d
    return False, {lit("the bulb of " + bn + " is not between the fingers: %.3f m from the grasp point (limit " + md + ")")} % d, {md} - d
"""
    return check_fn(c, body)


def bulbjaw(c: Spec) -> str:
    """Parts: [left finger (point), right finger (point)]. The jaw opening is about the bulb's width."""
    fl, fr = c["element_ids"][:2]
    lo, hi = num(c["thresholds"]["min_jaw"]), num(c["thresholds"]["max_jaw"])
    body = f"""
    jaw = distance(E[{fl}], E[{fr}])
    margin = np.min([jaw - {lo}, {hi} - jaw])
    if jaw >= {lo} and jaw <= {hi}:
        return True, "the jaws are closed on the bulb (%.3f m apart)" % jaw, margin
    return False, "the jaws are not closed on the bulb: %.3f m apart (on the bulb {lo} to {hi}; closed on nothing 0, open 0.08)" % jaw, margin
"""
    return check_fn(c, body)


def bulbseated(c: Spec) -> str:
    """Parts: [bulb (point), socket (point)]. The bulb stays over its socket and does not rise."""
    b, s = c["element_ids"][:2]
    mo, mr, bn = num(c["thresholds"]["max_off"]), num(c["thresholds"]["max_rise"]), obj_name(c, 0)
    body = f"""
    off = horizontal_distance(E[{b}], centroid(E[{s}]))
    rise = centroid(E[{b}])[2] - centroid(H[{b}][0])[2]
    margin = np.min([{mo} - off, {mr} - rise])
    if off <= {mo} and rise <= {mr}:
        return True, {lit("the bulb of " + bn + " is on its socket (%.3f m off it sideways, risen %.3f m)")} % (off, rise), margin
    return False, {lit("the bulb of " + bn + " left its socket: %.3f m off it sideways, risen %.3f m since the screw began")} % (off, rise), margin
"""
    return check_fn(c, body)


def screwed(c: Spec) -> str:
    """Parts: [bulb (point), socket (point)]. The bulb's centre at most ``max_above`` above the socket's."""
    b, k = c["element_ids"][0], c["element_ids"][1]
    ma, bn = num(c["thresholds"]["max_above"]), obj_name(c, 0)
    body = f"""
    above = centroid(E[{b}])[2] - centroid(E[{k}])[2]
    if above <= {ma}:
        return True, {lit("the bulb of " + bn + " is screwed in: %.4f m above the socket")} % above, {ma} - above
    return False, {lit("the bulb of " + bn + " is not screwed in: %.4f m above the socket (at most " + ma + ")")} % above, {ma} - above
"""
    return check_fn(c, body)


# --- the rule ----------------------------------------------------------------------------------------------
def next_subgoal(goal: BulbGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    lamp = goal.lamp
    g = answer(f"grasp the bulb of {nice(lamp)}", "grasp", {"obj": lamp, "part": "bulb"}, grasp(lamp), "")
    s = answer(f"screw the bulb of {nice(lamp)} in by {TURNS:g} turn", "screw", {"obj": lamp, "turns": TURNS},
               screw(lamp), "")
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in ("grasp", "screw"):
        if previous and previous.get("done"):
            return done("the bulb is screwed in")
        g["reasoning"] = "the bulb sits loose in its socket: grasp it, then screw it in"
        return g
    kind = failed_kind(feedback)
    if kind == "success":
        if skill == "grasp":
            s["reasoning"] = "the bulb is held; turn it clockwise one turn, following the thread down, then let go"
            return s
        return done("the bulb is screwed in")
    if kind == "freed":
        s["reasoning"] = "the bulb is still held after the screw; screw again, which ends by letting go"
        return s
    g["reasoning"] = f"the bulb is not held or not screwed in ({kind}); grasp it again, then screw it"
    return g


FAMILY = TaskFamily(
    name="bulb",
    task="screw-bulb",
    summary="screw the light bulb into its socket",
    example="screw in the light bulb",
    understand=understand,
    next_subgoal=next_subgoal,
    scene=scene,
    thresholds=THRESHOLDS,
    templates={"bulbgrip": bulbgrip, "bulbjaw": bulbjaw, "bulbseated": bulbseated, "screwed": screwed},
)
