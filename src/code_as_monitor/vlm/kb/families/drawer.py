# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``drawer`` (task ``open-drawer``): understanding, constraint builders, thresholds, templates
and recovery.

Family ``drawer`` ("open the drawer by pulling its handle"): ``grasp`` the cabinet's handle -> ``pull`` the
drawer out its opening plus ``PULL_MARGIN`` (then the gripper lets go) -> done.

How far: ``DRAWER_OPEN`` (15 cm), or a length ("open the drawer 10 cm", "by 4 inches", "at least 8 cm": at
least that far out), "halfway" (12.5 cm, half the 25 cm travel) or "slightly" / "a little" / "a bit"
(``MIN_OPEN``), from ``MIN_OPEN`` to ``MAX_OPEN``: the task's ``min_open`` (its success check follows) and the
pull checks' ``min_open``. Refused, naming the words: upper limits ("up to", "exactly": the pull is checked from
below only), lengths out of range, two lengths, "fully" (a re-pull after a slip would run into the stop, see below). Elements, all points: the gripper's grasp
point (``robot/tip``), the handle bar's centre (``drawer_cabinet/handle``), the drawer front
(``drawer_cabinet/drawer``) and the cabinet's body (``drawer_cabinet/frame``); the drawer's axis is the
horizontal direction from the body to the drawer front, its travel is the handle's motion along that axis
over the element history ``H`` (see the templates below). The grasp is judged
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
remaining distance; the drawer's 25 cm travel leaves room for a slip at up to 8 cm plus a full pull of at
most ``MAX_OPEN`` + ``PULL_MARGIN``, which is why longer openings are refused.

Thresholds: Physical tolerances from the object sizes in sim/assets, never fitted to evaluation outcomes. Units: metres,
radians, fractions.

Sizes used (``sim/assets/drawer_cabinet.urdf``): the handle is a bar 10 cm long and 1.2 cm thick, 3.5 cm in
front of the drawer front; the drawer's tray is 22 cm deep; the gripper's fingers are 4.5 cm long and
its grasp point sits between them; its jaws open 8 cm.

Templates: same rules as :mod:`code_as_monitor.vlm.kb.shared.codegen`: one decision per check (so path coverage reaches both
branches), literal ``True``/``False`` returns, reasons with every measurement, only ``np``, ``math`` and the
monitor helpers. Element order in a constraint's parts is the contract with the builders above:
``tip`` the gripper's grasp point, ``handle`` the handle bar's centre, ``drawer`` the drawer front and
``frame`` the cabinet's body, ``finger_left``/``finger_right`` the gripper's jaws (proprioception; their
distance is the jaw opening), all points (world metres).

How far the drawer came out: the drawer's axis is the horizontal direction from the frame's point to the
drawer front's point (the front sits ahead of the cabinet's body along the axis, and only the direction is
used, so a few cm of painting error in either point tilt it by a few degrees). The drawer front's travel is
measured on its handle, a compact bar fixed to the front whose painted point is the same however far the
drawer is out (the drawer's own visible area grows as its tray comes out, which moves its painted centre):
``opened`` = |(handle now - handle at the oldest frame of ``H``) . axis|, metres. ``H`` starts with the subgoal,
so this is the travel since the pull began. The sign is dropped: on its rails a drawer that starts the pull
closed or a few cm out (after a slip) can only travel ``min_open`` by coming out, and path coverage's moving
histories point in random directions, so a signed test leaves its True branch unreached for some cabinet
headings. (The projection still ignores sideways drift of the tracked point.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name
from code_as_monitor.vlm.kb.shared.feedback import failed_kind
from code_as_monitor.vlm.kb.shared.grip import FINGER_LEFT, FINGER_RIGHT, GRIP_TIP, freed, part_spec
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

DRAWER_OPEN = 0.15
"""Metres a drawer must come out to count as open: more than half of a 22 cm deep tray, enough to reach in."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # grasp, during (proactive): the handle stays where it is (within 2 cm) while the gripper approaches and
    # closes; a drawer pushed or pulled by 2 cm moves the 1.2 cm bar out of the closing jaws, which then close
    # on nothing. (The grasp does not lift the handle, so a held handle stays put as well.)
    "drawer_still": {"max_disp": 0.02},
    # grasp, upon: the handle's centre within 3 cm of the grasp point: jaws closed on a 1.2 cm bar hold it
    # within 1 cm, plus up to 2 cm for a handle point painted from the bar's visible pixels beside the fingers.
    "drawer_handle_grip": {"max_dist": 0.03},
    # grasp, upon: the jaws are closed on the bar: their opening between 1 cm and 5 cm (open it is 8 cm,
    # closed on nothing 0; on the 1.2 cm bar the fingers' pads leave a little clearance either side). The
    # handle is not lifted, so without this the grasp would look done while the open gripper passes the bar
    # on its way down.
    "drawer_jaw_shut": {"min_jaw": 0.01, "max_jaw": 0.05},
    # pull, during (reactive): the handle stays within 3 cm of the grasp point (as above) while the drawer is
    # less than DRAWER_OPEN out; once it is that far out, letting go is the plan.
    "drawer_handled": {"max_dist": 0.03, "min_open": DRAWER_OPEN},
    # pull, upon: the drawer front (its handle) has come out DRAWER_OPEN along the drawer's axis since the
    # pull began.
    "drawer_pulled": {"min_open": DRAWER_OPEN},
    # pull, upon: released: the grasp point 6 cm from the handle, beyond the 3 cm grip tolerance plus the
    # fingers' 3 cm reach past the bar (4.5 cm fingers, grasp point 5 mm inside their ends, 1.2 cm bar).
    "drawer_freed": {"release_dist": 0.06},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


PULL_MARGIN = 0.02
"""Metres the pull goes beyond the opening asked for: for a grasp that lags the tool a little and for the painted
points' noise."""
PULL_DISTANCE = round(DRAWER_OPEN + PULL_MARGIN, 3)
"""Metres the pull moves the handle for the default opening."""
DRAWER_TRAVEL = 0.25
"""Metres the drawer runs on its rails (``sim/assets/drawer_cabinet.urdf``)."""
MIN_OPEN = 0.05
"""The smallest opening the kb plans: below 5 cm the handle's travel is within the 2-3 cm tolerances of the
painted points (``drawer_still``, ``drawer_handle_grip``), so the monitor could not tell it from a still drawer."""
MAX_OPEN = DRAWER_OPEN
"""The largest opening the kb plans: a slip at up to 8 cm then a full re-pull of ``MAX_OPEN`` + ``PULL_MARGIN``
still fits the 25 cm travel (the stateless rule re-pulls the whole distance)."""


@dataclass(frozen=True)
class DrawerGoal:
    """The cabinet, the part to grasp (its handle) and how far the drawer must come out (metres)."""

    obj: str
    target: str = "handle"
    min_open: float = DRAWER_OPEN


VERBS = ("open", "pull", "slide", "grasp", "use")
MODIFIERS = ("out", "open", "by_handle", "halfway", "slightly")
HEADS = ("drawer", "cabinet", "handle")
DOING = (f"opens the drawer by pulling its handle out along its rails, 15 cm or a length from "
         f"{MIN_OPEN * 100:.0f} to {MAX_OPEN * 100:.0f} cm")


def claims(ins: Instruction) -> bool:
    return bool({"drawer", "cabinet"} & ins.heads) or ("handle" in ins.heads and not {"teapot", "pot"} & ins.heads)


def understand(ins: Instruction, objects: list[str]) -> DrawerGoal | None:
    """The cabinet grounded on ``objects``; None when the instruction is not about opening a drawer."""
    if not claims(ins):
        return None
    r = Reading(ins, "open-drawer", heads=HEADS, verbs=VERBS)
    r.verbs(VERBS, DOING, once=True)
    if "fully" in ins.modifiers:
        r.refuse(f"cannot open the drawer all the way (its {DRAWER_TRAVEL * 100:.0f} cm travel): the kb opens it "
                 f"{MIN_OPEN * 100:.0f} to {MAX_OPEN * 100:.0f} cm, so that a re-pull after a slip fits the rails "
                 f"(say e.g. 'open the drawer 15 cm')")
    r.modifiers(MODIFIERS, DOING)
    if not {"open", "pull", "slide"} & set(ins.verbs) and "open" not in ins.modifiers:
        r.refuse("say what to do with the drawer: open it")
    parts = r.phrases(lambda p: p.head in HEADS)
    if not r.phrases(lambda p: p.head in ("drawer", "handle")):
        r.refuse("which drawer? say 'the drawer'")
    for p in parts:
        q = ins.resolve(p.index)
        if q.colour or q.position or q.ordinal or (q.quantity is not None and (
                q.quantity.value != 1 or q.quantity.of_total not in (None, 1))):
            r.refuse(f"{p.text!r}: the scene has one drawer with one handle")
        r.use(p.index)
    for k in ins.links:
        a = ins.resolve(k.a).head if k.a is not None else ""
        b = ins.resolve(k.b).head
        if (k.kind == "of" and a in ("handle", "drawer") and b in ("drawer", "cabinet")) or (
                k.kind in ("by", "with", "at") and b == "handle") or (k.kind in ("from", "out_of") and b == "cabinet"):
            r.use_link(k)
    min_open = _opening(r)
    cabinet = next((o for o in scene_names(objects) if "drawer" in o or "cabinet" in o), "")
    if not cabinet:
        r.refuse("the scene has no drawer")
    r.finish()
    return DrawerGoal(cabinet, "handle", min_open)


def _opening(r: Reading) -> float:
    """Metres the drawer must come out: a length, "halfway", "slightly" (``MIN_OPEN``, the least the kb opens it), or
    the default (the measures are marked used)."""
    ins = r.ins
    halfway, slightly = "halfway" in ins.modifiers, "slightly" in ins.modifiers
    if len(ins.measures) + halfway + slightly > 1:
        r.refuse("say one opening, e.g. 'open the drawer 10 cm'")
    if not ins.measures:
        return round(DRAWER_TRAVEL / 2, 4) if halfway else MIN_OPEN if slightly else DRAWER_OPEN
    m = ins.measures[0]
    r.used_measures.add(0)
    if m.kind != "length":
        r.refuse(f"a drawer opens by a length, not by {m.text!r} (say e.g. 'open the drawer 10 cm')")
    if m.bound not in ("plain", "about", "at_least", "more"):
        r.refuse(f"cannot promise {m.text!r}: the kb pulls a little past the opening asked for and checks "
                 f"that the drawer came out at least that far (say e.g. 'open the drawer 10 cm')")
    if not MIN_OPEN - 1e-9 <= m.metres <= MAX_OPEN + 1e-9:
        r.refuse(f"cannot open the drawer {m.text!r} ({m.metres * 100:.1f} cm): the kb opens it "
                 f"{MIN_OPEN * 100:.0f} to {MAX_OPEN * 100:.0f} cm")
    return round(m.metres, 4)


def scene(ins: Instruction) -> list[str] | None:
    """The open-drawer scene's objects, or None."""
    return ["drawer_cabinet", "table"] if claims(ins) else None


# --- elements and constraint builders ------------------------------------------------------------------


def _handle(obj: str) -> dict[str, str]:
    return part_spec(obj, "handle", "point", "handle")


def _front(obj: str) -> dict[str, str]:
    return part_spec(obj, "drawer", "point", "drawer front")


def _frame(obj: str) -> dict[str, str]:
    return part_spec(obj, "frame", "point", "frame")


def grasp(obj: str) -> list[dict[str, Any]]:
    """``grasp`` the handle: during (proactive) the handle stays put; upon, it is at the grasp point and the jaws
    are closed (no lift: the drawer runs on its rails)."""
    st, gr, js = _thr("drawer_still"), _thr("drawer_handle_grip"), _thr("drawer_jaw_shut")
    return [
        constraint(f"drawerstill_{obj}", f"the handle of {nice(obj)} stays where it is (within {st['max_disp'] * 100:.0f} cm) "
           f"while the gripper approaches and closes; if the drawer moves, the jaws close on nothing", "during", True,
           st, [_handle(obj)]),
        constraint(f"handlegrip_{obj}", f"the handle of {nice(obj)} is between the fingers: its centre within "
           f"{gr['max_dist'] * 100:.0f} cm of the grasp point", "upon", False, gr, [GRIP_TIP, _handle(obj)]),
        constraint(f"jawshut_{obj}", f"the gripper's jaws are closed on the handle of {nice(obj)}: their opening between "
           f"{js['min_jaw'] * 100:.1f} and {js['max_jaw'] * 100:.0f} cm", "upon", False, js,
           [FINGER_LEFT, FINGER_RIGHT]),
    ]


def pull(obj: str, min_open: float = DRAWER_OPEN) -> list[dict[str, Any]]:
    """``pull``: during, the handle stays in the gripper until the drawer is out; upon, the drawer front came out
    ``min_open`` along its axis (element history) and the gripper let go."""
    hd, pu, fr = _thr("drawer_handled"), _thr("drawer_pulled"), _thr("drawer_freed")
    hd["min_open"] = pu["min_open"] = min_open
    return [
        constraint(f"handled_{obj}", f"the handle of {nice(obj)} stays in the gripper (within {hd['max_dist'] * 100:.0f} cm "
           f"of the grasp point) until the drawer is out {hd['min_open'] * 100:.0f} cm; if the grasp slips off, the "
           f"gripper pulls nothing", "during", False, hd, [GRIP_TIP, _handle(obj), _front(obj), _frame(obj)]),
        constraint(f"pulled_{obj}", f"the drawer front of {nice(obj)} came out at least {pu['min_open'] * 100:.0f} cm along "
           f"the drawer's axis since the pull began", "upon", False, pu, [_handle(obj), _front(obj), _frame(obj)]),
        constraint(f"drawerfreed_{obj}", f"the handle of {nice(obj)} is released: the grasp point at least "
           f"{fr['release_dist'] * 100:.0f} cm from it", "upon", False, fr, [GRIP_TIP, _handle(obj)]),
    ]


# --- the rule ----------------------------------------------------------------------------------------------
REGRASP = ("drawerstill", "handlegrip", "jawshut", "handled", "pulled")


def next_drawer(obj: str, target: str, previous: dict[str, Any] | None, kind: str,
                min_open: float = DRAWER_OPEN) -> dict[str, Any]:
    """The next subgoal; ``kind`` is the failed constraint's key (or ``success``). ``target`` is the part to
    grasp (``handle``); ``min_open`` how far the drawer must come out (metres)."""
    part = target or "handle"
    distance = round(min_open + PULL_MARGIN, 4)
    g = answer(f"grasp the {part} of {nice(obj)}", "grasp", {"obj": obj, "part": part}, grasp(obj), "")
    p = answer(f"pull the drawer of {nice(obj)} open by {round(distance * 100, 1):g} cm", "pull",
               {"obj": obj, "distance": distance}, pull(obj, min_open), "")
    fin = done("the drawer is open and released")
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in ("grasp", "pull"):
        if previous and previous.get("done"):
            return fin
        g["reasoning"] = "the drawer is closed: grasp its handle first, then pull it out along its rails"
        return g
    if kind == "success":
        if skill == "grasp":
            p["reasoning"] = (f"the handle is held; pull straight out along the drawer's axis, "
                              f"{round(distance * 100, 1):g} cm (the opening asked for, {round(min_open * 100, 1):g} cm, "
                              f"plus a "
                              f"margin), then let go")
            return p
        return fin
    if kind in REGRASP or (skill == "grasp" and kind == "other"):
        g["reasoning"] = (f"the handle is not in the gripper or the drawer is not out far enough ({kind}); grasp "
                          f"the handle again where it is now, then pull again")
        return g
    p["reasoning"] = f"the pull did not finish ({kind}); pull again, which ends by letting go"
    return p


def next_subgoal(goal: DrawerGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    return next_drawer(goal.obj, goal.target, previous, failed_kind(feedback), goal.min_open)


def task_params(goal: DrawerGoal) -> dict[str, object]:
    """The open-drawer task's goal parameter: how far the drawer must be open."""
    return {"min_open": goal.min_open}


# --- templates ---------------------------------------------------------------------------------------------
def _opened(h: int, dr: int, fr: int) -> str:
    """Lines computing ``axis`` (3,) and ``opened`` (metres out along it since the oldest frame of H)."""
    return f"""
    axis = centroid(E[{dr}]) - centroid(E[{fr}])
    axis = np.array([axis[0], axis[1], 0.0]) / (np.linalg.norm(axis[:2]) + 1e-9)
    opened = np.abs(np.dot(centroid(E[{h}]) - centroid(H[{h}][0]), axis))
"""


def drawerstill(c: Spec) -> str:
    """Parts: [handle (point)]. The handle has not moved since the grasp began (it is never lifted: a grasped
    handle stays where it is too, so this needs no "unless held" escape)."""
    (h,) = c["element_ids"][:1]
    th, hn = c["thresholds"], obj_name(c, 0)
    mx = num(th["max_disp"])
    body = f"""
    m = displacement(H[{h}])
    if m <= {mx}:
        return True, {lit("the handle of " + hn + " stays where it was (moved %.3f m)")} % m, {mx} - m
    return False, {lit("the handle of " + hn + " moved %.3f m while the gripper approached: the drawer moved and the jaws will close on nothing")} % m, {mx} - m
"""
    return check_fn(c, body)


def handlegrip(c: Spec) -> str:
    """Parts: [tip (point), handle (point)]. The handle's centre is at the grasp point."""
    tip, h = c["element_ids"][:2]
    th, hn = c["thresholds"], obj_name(c, 1)
    md = num(th["max_dist"])
    body = f"""
    d = distance(E[{tip}], centroid(E[{h}]))
    if d <= {md}:
        return True, {lit("the handle of " + hn + " is between the fingers (%.3f m from the grasp point)")} % d, {md} - d
    return False, {lit("the handle of " + hn + " is not between the fingers: %.3f m from the grasp point (limit " + md + ")")} % d, {md} - d
"""
    return check_fn(c, body)


def jawshut(c: Spec) -> str:
    """Parts: [left finger (point), right finger (point)]. The jaws are closed on something about the handle's
    width: their opening (the fingers' distance) between ``min_jaw`` and ``max_jaw``."""
    fl, fr = c["element_ids"][:2]
    th = c["thresholds"]
    lo, hi = num(th["min_jaw"]), num(th["max_jaw"])
    body = f"""
    jaw = distance(E[{fl}], E[{fr}])
    margin = np.min([jaw - {lo}, {hi} - jaw])
    if jaw >= {lo} and jaw <= {hi}:
        return True, "the jaws are closed on the handle (%.3f m apart)" % jaw, margin
    return False, "the jaws are not closed on the handle: %.3f m apart (open they are 0.08 m apart, closed on nothing 0; on the handle {lo} to {hi})" % jaw, margin
"""
    return check_fn(c, body)


def handled(c: Spec) -> str:
    """Parts: [tip (point), handle (point), drawer front (point), frame (point)]. The handle stays at the grasp
    point while the pull goes on, unless the drawer is already out by ``min_open`` (letting go is the plan)."""
    tip, h, dr, fr = c["element_ids"][:4]
    th, hn = c["thresholds"], obj_name(c, 1)
    md, mo = num(th["max_dist"]), num(th["min_open"])
    body = _opened(h, dr, fr) + f"""
    d = distance(E[{tip}], centroid(E[{h}]))
    margin = np.max([{md} - d, opened - {mo}])
    if d <= {md} or opened >= {mo}:
        return True, {lit("the handle of " + hn + " is in the gripper or the drawer is already out (%.3f m from the grasp point, drawer out %.3f m)")} % (d, opened), margin
    return False, {lit("the grasp slipped off the handle of " + hn + ": the handle is %.3f m from the grasp point and the drawer came out only %.3f m")} % (d, opened), margin
"""
    return check_fn(c, body)


def pulled(c: Spec) -> str:
    """Parts: [handle (point), drawer front (point), frame (point)]. The drawer came out ``min_open`` along its
    axis since the pull began."""
    h, dr, fr = c["element_ids"][:3]
    th, hn = c["thresholds"], obj_name(c, 0)
    mo = num(th["min_open"])
    body = _opened(h, dr, fr) + f"""
    if opened >= {mo}:
        return True, {lit("the drawer of " + hn + " came out %.3f m along its axis")} % opened, opened - {mo}
    return False, {lit("the drawer of " + hn + " came out only %.3f m along its axis (needs " + mo + ")")} % opened, opened - {mo}
"""
    return check_fn(c, body)


def drawerfreed(c: Spec) -> str:
    """Parts: [tip (point), handle (point)]. The gripper has let go of the handle and moved off it."""
    return freed(c, "the handle of " + obj_name(c, 1))


FAMILY = TaskFamily(
    name="drawer",
    task="open-drawer",
    summary="open the drawer by pulling its handle, 15 cm or as far as asked from 5 to 15 cm",
    example="open the drawer by pulling its handle",
    understand=understand,
    next_subgoal=next_subgoal,
    scene=scene,
    task_params=task_params,
    thresholds=THRESHOLDS,
    templates={"drawerstill": drawerstill, "handlegrip": handlegrip, "jawshut": jawshut, "handled": handled,
               "pulled": pulled, "drawerfreed": drawerfreed},
)
