"""kb rules for ``open-drawer``: understanding, constraint builders and the stateless next-subgoal rule.

Family ``drawer`` ("open the drawer by pulling its handle"): ``grasp`` the cabinet's handle -> ``pull`` the
drawer out ``PULL_DISTANCE`` (then the gripper lets go) -> done. Elements, all points: the gripper's grasp
point (``robot/tip``), the handle bar's centre (``drawer_cabinet/handle``), the drawer front
(``drawer_cabinet/drawer``) and the cabinet's body (``drawer_cabinet/frame``); the drawer's axis is the
horizontal direction from the body to the drawer front, its travel is the handle's motion along that axis
over the element history ``H`` (see :mod:`code_as_monitor.vlm.kb.drawer_templates`). The grasp is judged
with the gripper's two fingers too (``robot/finger_left``, ``robot/finger_right``, proprioception): the handle
is not lifted, so only the closed jaws tell a grasp from an open gripper passing the bar.

Recovery by the failed constraint's id prefix (``"failure: <id>: <reason>"``):

======================================================= ==========================================
failed                                                  next subgoal
======================================================= ==========================================
drawerstill (the handle moved before the grasp),         grasp the handle again (where it is now)
handlegrip/jawshut (not in the closed gripper), handled
(the grasp slipped off mid-pull), pulled (not out far)
drawerfreed (still held after the pull)                  pull again (it ends by letting go)
======================================================= ==========================================

After a slip the next pull is again ``PULL_DISTANCE`` from wherever the drawer stopped: the kb is stateless
(it sees the failed constraint's id, not how far the drawer came out), so it cannot ask for just the
remaining distance; the drawer's 25 cm travel leaves room for a slip at up to 8 cm plus a full pull.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.vlm.kb.drawer_thresholds import DRAWER_OPEN
from code_as_monitor.vlm.kb.grip import GRIP_TIP, part_spec
from code_as_monitor.vlm.kb.skills import _c, answer, nice
from code_as_monitor.vlm.kb.thresholds import thresholds

PULL_DISTANCE = round(DRAWER_OPEN + 0.02, 3)
"""Metres the pull moves the handle: the opening asked for plus 2 cm, for a grasp that lags the tool a little
and for the painted points' noise."""


def understand(instruction: str, objects: list[str]) -> tuple[str, str] | None:
    """(cabinet, part to grasp) grounded on ``objects`` when the instruction asks to open a drawer, else None."""
    s = instruction.lower()
    if "drawer" not in s or not any(w in s for w in ("open", "pull")):
        return None
    names = [o for o in objects if "/" not in o]
    cabinet = next((o for o in names if "drawer" in o or "cabinet" in o), "")
    return (cabinet, "handle") if cabinet else None


def infer_objects(instruction: str) -> list[str] | None:
    """The simulator's object list for this task's instruction, or None."""
    s = instruction.lower()
    if "drawer" in s and any(w in s for w in ("open", "pull")):
        return ["drawer_cabinet", "table"]
    return None


# --- elements and constraint builders ------------------------------------------------------------------
FINGER_LEFT = {"name": "gripper left finger", "obj": "robot", "part": "finger_left", "kind": "point"}
FINGER_RIGHT = {"name": "gripper right finger", "obj": "robot", "part": "finger_right", "kind": "point"}
"""The gripper's jaws at the grasp point's depth, from proprioception; their distance is the jaw opening."""


def _handle(obj: str) -> dict[str, str]:
    return part_spec(obj, "handle", "point", "handle")


def _front(obj: str) -> dict[str, str]:
    return part_spec(obj, "drawer", "point", "drawer front")


def _frame(obj: str) -> dict[str, str]:
    return part_spec(obj, "frame", "point", "frame")


def grasp(obj: str) -> list[dict[str, Any]]:
    """``grasp`` the handle: during (proactive) the handle stays put; upon, it is at the grasp point and the jaws
    are closed (no lift: the drawer runs on its rails)."""
    st, gr, js = thresholds("drawer_still"), thresholds("drawer_handle_grip"), thresholds("drawer_jaw_shut")
    return [
        _c(f"drawerstill_{obj}", f"the handle of {nice(obj)} stays where it is (within {st['max_disp'] * 100:.0f} cm) "
           f"while the gripper approaches and closes; if the drawer moves, the jaws close on nothing", "during", True,
           st, [_handle(obj)]),
        _c(f"handlegrip_{obj}", f"the handle of {nice(obj)} is between the fingers: its centre within "
           f"{gr['max_dist'] * 100:.0f} cm of the grasp point", "upon", False, gr, [GRIP_TIP, _handle(obj)]),
        _c(f"jawshut_{obj}", f"the gripper's jaws are closed on the handle of {nice(obj)}: their opening between "
           f"{js['min_jaw'] * 100:.1f} and {js['max_jaw'] * 100:.0f} cm", "upon", False, js,
           [FINGER_LEFT, FINGER_RIGHT]),
    ]


def pull(obj: str) -> list[dict[str, Any]]:
    """``pull``: during, the handle stays in the gripper until the drawer is out; upon, the drawer front came out
    ``DRAWER_OPEN`` along its axis (element history) and the gripper let go."""
    hd, pu, fr = thresholds("drawer_handled"), thresholds("drawer_pulled"), thresholds("drawer_freed")
    return [
        _c(f"handled_{obj}", f"the handle of {nice(obj)} stays in the gripper (within {hd['max_dist'] * 100:.0f} cm "
           f"of the grasp point) until the drawer is out {hd['min_open'] * 100:.0f} cm; if the grasp slips off, the "
           f"gripper pulls nothing", "during", False, hd, [GRIP_TIP, _handle(obj), _front(obj), _frame(obj)]),
        _c(f"pulled_{obj}", f"the drawer front of {nice(obj)} came out at least {pu['min_open'] * 100:.0f} cm along "
           f"the drawer's axis since the pull began", "upon", False, pu, [_handle(obj), _front(obj), _frame(obj)]),
        _c(f"drawerfreed_{obj}", f"the handle of {nice(obj)} is released: the grasp point at least "
           f"{fr['release_dist'] * 100:.0f} cm from it", "upon", False, fr, [GRIP_TIP, _handle(obj)]),
    ]


# --- the rule ----------------------------------------------------------------------------------------------
REGRASP = ("drawerstill", "handlegrip", "jawshut", "handled", "pulled")


def next_drawer(obj: str, target: str, previous: dict[str, Any] | None, kind: str) -> dict[str, Any]:
    """The next subgoal; ``kind`` is the failed constraint's key (or ``success``). ``target`` is the part to
    grasp (``handle``)."""
    part = target or "handle"
    g = answer(f"grasp the {part} of {nice(obj)}", "grasp", {"obj": obj, "part": part}, grasp(obj), "")
    p = answer(f"pull the drawer of {nice(obj)} open by {PULL_DISTANCE * 100:.0f} cm", "pull",
               {"obj": obj, "distance": PULL_DISTANCE}, pull(obj), "")
    done = {"subgoal": "task complete", "done": True, "action": None, "constraints": [],
            "reasoning": "the drawer is open and released"}
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in ("grasp", "pull"):
        if previous and previous.get("done"):
            return done
        g["reasoning"] = "the drawer is closed: grasp its handle first, then pull it out along its rails"
        return g
    if kind == "success":
        if skill == "grasp":
            p["reasoning"] = (f"the handle is held; pull straight out along the drawer's axis, "
                              f"{PULL_DISTANCE * 100:.0f} cm (the opening asked for plus a margin), then let go")
            return p
        return done
    if kind in REGRASP or (skill == "grasp" and kind == "other"):
        g["reasoning"] = (f"the handle is not in the gripper or the drawer is not out far enough ({kind}); grasp "
                          f"the handle again where it is now, then pull again")
        return g
    p["reasoning"] = f"the pull did not finish ({kind}); pull again, which ends by letting go"
    return p
