"""kb rules for the gripper tasks: understanding, constraint builders and the stateless next-subgoal rule.

Family ``pen`` ("put the pen into the pen holder"): ``grasp`` the pen by its body -> ``reorient`` it
upright -> ``insert`` it into the holder -> done. Elements: the gripper's grasp point (``robot/tip``,
point), the pen axis (``pen/body``, a LINE: its two ends), the pen tip (``pen/tip``, point), the
holder's opening (``pen_holder/rim``, a SURFACE: the rim's corners; its centroid is the opening's
centre, which a point element on a ring would miss).

Recovery (next subgoal = f(instruction, objects, previous subgoal, feedback)), by the failed
constraint's id prefix in the feedback (``"failure: <id>: <reason>"``), keywords as a fallback:

============ ============================================= =================
failed       meaning                                       next subgoal
============ ============================================= =================
steady/grasped/lifted  moved away / not in the gripper   grasp again
gripped       the held object dropped                        grasp again
carried       dropped before its tip is inside the opening   grasp again
upright       the object is not upright                      reorient again
over          the holder moved away under the pen            reorient (lifts it upright), then insert
inside        the pen did not end up in the holder           grasp again
freed         still held after the insertion                 insert again
============ ============================================= =================
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.kb.feedback import classify
from code_as_monitor.vlm.kb.grip import GRIP_TIP, in_gripper, part_spec, still_gripped
from code_as_monitor.vlm.kb.skills import _c, answer, nice
from code_as_monitor.vlm.kb.thresholds import thresholds


@dataclass(frozen=True)
class ManipTask:
    """What the kb understood of a gripper task: ``family`` and the grounded object names."""

    family: str
    obj: str = ""
    target: str = ""


def understand(instruction: str, objects: list[str]) -> ManipTask | None:
    """Ground a gripper-task instruction on the scene's objects; None when no rule applies."""
    s = instruction.lower()
    names = [o for o in objects if "/" not in o]
    if "pen" in s and "holder" in s:
        pen = next((o for o in names if o == "pen" or o.endswith("_pen")), "")
        holder = next((o for o in names if "holder" in o), "")
        if pen and holder:
            return ManipTask("pen", pen, holder)
    if "book" in s and "shelf" in s:
        book = next((o for o in names if o == "book" or o.endswith("_book")), "")
        shelf = next((o for o in names if "shelf" in o), "")
        if book and shelf:
            return ManipTask("book", book, shelf)
    from code_as_monitor.vlm.kb import drawer, tea

    for family, rule in (("tea", tea.understand), ("drawer", drawer.understand)):
        got = rule(instruction, objects)
        if got is not None:
            return ManipTask(family, *got)
    return None


def infer_objects(instruction: str) -> list[str] | None:
    """The simulator's object list for a gripper-task instruction, or None."""
    s = instruction.lower()
    if "pen" in s and "holder" in s:
        return ["pen", "pen_holder", "table"]
    if "book" in s and "shelf" in s:
        return ["book", "bookshelf", "table"]
    from code_as_monitor.vlm.kb import drawer, tea

    return tea.infer_objects(instruction) or drawer.infer_objects(instruction)


# --- constraint builders ---------------------------------------------------------------------------
def _axis(obj: str) -> dict[str, str]:
    return part_spec(obj, "body", "line", "axis")


def _end(obj: str) -> dict[str, str]:
    return part_spec(obj, "tip", "point", "tip")


def _opening(obj: str) -> dict[str, str]:
    return part_spec(obj, "rim", "surface", "opening")


def grasp(obj: str) -> list[dict[str, Any]]:
    """``grasp``: during (proactive) the object stays put until gripped; upon, it is gripped, and lifted."""
    st, li = thresholds("steady"), thresholds("lifted")
    return [
        _c(f"steady_{obj}", f"{nice(obj)} stays where it lies (within {st['max_disp'] * 100:.0f} cm) until it is "
           f"between the fingers; if it moves the fingers close on nothing", "during", True, st,
           [GRIP_TIP, _axis(obj)]),
        *in_gripper(obj, _axis(obj), li),
    ]


def reorient(obj: str) -> list[dict[str, Any]]:
    """``reorient``: during, still gripped; upon, the object's axis (a line) within 15 degrees of vertical."""
    gr, up = thresholds("gripped"), thresholds("upright_turned")
    return [
        still_gripped(obj, _axis(obj), gr),
        _c(f"upright_{obj}", f"{nice(obj)} is upright: its axis within 15 degrees of vertical", "upon", False, up,
           [_axis(obj)]),
    ]


def insert(obj: str, target: str) -> list[dict[str, Any]]:
    """``insert``: during, gripped, near vertical, tip over the opening when low; upon, inside and released."""
    gr, up, ov = thresholds("gripped"), thresholds("upright_carried"), thresholds("over")
    ins, fr = thresholds("inside"), thresholds("freed")
    return [
        _c(f"carried_{obj}", f"{nice(obj)} stays in the gripper (within {gr['max_dist'] * 100:.0f} cm of the grasp "
           f"point) until its tip is inside {nice(target)}", "during", False, {**gr, **ins},
           [GRIP_TIP, _axis(obj), _end(obj), _opening(target)]),
        _c(f"upright_{obj}", f"{nice(obj)} stays near vertical (its axis within 25 degrees of vertical) while it is "
           f"carried and inserted", "during", False, up, [_axis(obj)]),
        _c(f"over_{target}", f"the tip of {nice(obj)} is above the opening of {nice(target)} (within "
           f"{ov['max_offset'] * 100:.1f} cm of its centre) whenever it is lower than {ov['approach'] * 100:.0f} cm "
           f"above the rim", "during", True, ov, [_end(obj), _opening(target)]),
        _c(f"inside_{target}", f"the tip of {nice(obj)} is inside the opening of {nice(target)}, at least "
           f"{ins['min_depth'] * 100:.0f} cm below the rim", "upon", False, ins, [_end(obj), _opening(target)]),
        _c(f"freed_{obj}", f"{nice(obj)} is released: the grasp point at least {fr['release_dist'] * 100:.0f} cm "
           f"from its centre", "upon", False, fr, [GRIP_TIP, _axis(obj)]),
    ]


# --- the rule --------------------------------------------------------------------------------------
_PREFIX_RE = re.compile(r"(?:failure|failed)\s*:\s*([a-z]+)_", re.I)
_KEYWORDS = (
    ("gripped", ("dropped", "no longer held", "not held")),
    ("carried", ("not inside and dropped",)),
    ("steady", ("moved", "close on nothing")),
    ("upright", ("upright", "vertical", "tilted")),
    ("over", ("not above the opening", "miss")),
    ("inside", ("not inside",)),
    ("freed", ("still held",)),
)


def failed_kind(feedback: str | None) -> str:
    """``"success"``, the failed constraint's template key (``gripped``, ``over``, ...) or ``"other"``."""
    if classify(feedback) == "success":
        return "success"
    m = _PREFIX_RE.search(feedback or "")
    if m:
        return m.group(1).lower()
    s = (feedback or "").lower()
    for kind, words in _KEYWORDS:
        if any(w in s for w in words):
            return kind
    return "other"


def _pen(task: ManipTask, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    pen, holder = task.obj, task.target
    g = answer(f"grasp {nice(pen)} by its body", "grasp", {"obj": pen, "part": "body"}, grasp(pen), "")
    r = answer(f"turn {nice(pen)} upright, tip down", "reorient", {"obj": pen, "axis": "vertical"}, reorient(pen), "")
    i = answer(f"insert {nice(pen)} into {nice(holder)}", "insert", {"obj": pen, "target": holder},
                insert(pen, holder), "")
    action = (previous or {}).get("action") or {}
    skill = action.get("skill")
    if not previous or skill not in ("grasp", "reorient", "insert"):
        if previous and previous.get("done"):
            return {"subgoal": "task complete", "done": True, "action": None, "constraints": [],
                    "reasoning": "the pen is in the holder"}
        g["reasoning"] = "the pen lies on the table: grasp it first, then turn it upright and insert it"
        return g
    kind = failed_kind(feedback)
    if kind == "success":
        if skill == "grasp":
            r["reasoning"] = "the pen is held; a pen only enters the holder tip first and near vertical"
            return r
        if skill == "reorient":
            i["reasoning"] = "the pen is upright; bring its tip above the opening and lower it in"
            return i
        return {"subgoal": "task complete", "done": True, "action": None, "constraints": [],
                "reasoning": "the pen is in the holder"}
    regrasp = ("steady", "grasped", "lifted", "gripped", "carried", "inside")
    if kind in regrasp or (skill == "grasp" and kind == "other"):
        g["reasoning"] = (f"the pen is not in the gripper or not in the holder ({kind}); grasp it again where it "
                          f"is now")
        return g
    if kind == "upright" or (skill == "reorient" and kind == "other"):
        r["reasoning"] = "the pen is not upright in the gripper; turn it upright again"
        return r
    if kind == "over":
        r["reasoning"] = ("the holder moved away under the pen, which is now low beside it: lift it upright to "
                          "carry height first, then insert it where the holder is now")
        return r
    i["reasoning"] = f"the insertion did not finish ({kind}); lift and insert again above where the holder is now"
    return i


def next_subgoal(task: ManipTask, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    """The generator answer for a gripper task."""
    if task.family == "book":
        from code_as_monitor.vlm.kb.book import next_book

        return next_book(task.obj, task.target, previous, failed_kind(feedback))
    if task.family == "tea":
        from code_as_monitor.vlm.kb.tea import next_tea

        return next_tea(task.obj, task.target, previous, failed_kind(feedback))
    if task.family == "drawer":
        from code_as_monitor.vlm.kb.drawer import next_drawer

        return next_drawer(task.obj, task.target, previous, failed_kind(feedback))
    return _pen(task, previous, feedback)
