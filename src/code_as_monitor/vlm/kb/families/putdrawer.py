# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``putdrawer`` (task ``put-in-drawer``): open the drawer, then put the block in it.

Plan: ``grasp`` the cabinet's handle -> ``pull`` the drawer out ``PULL_DISTANCE`` (it ends by letting go) ->
``grasp`` the block -> ``put_in`` the drawer -> done. The handle's grasp and the pull use the ``drawer`` family's
checks (``drawerstill``, ``handlegrip``, ``jawshut``, ``handled``, ``pulled``, ``drawerfreed``: the same templates,
with this family's thresholds: the drawer must come out ``PUT_OPEN``, enough for the block, not the 15 cm of
"open the drawer"); the block's grasp uses the shared grasp checks (``steady``, ``grasped``, ``lifted``).

Elements, all points: the grasp point (``robot/tip``), the handle (``drawer_cabinet/handle``), the drawer front
(``drawer_cabinet/drawer``), the cabinet's body (``drawer_cabinet/frame``), the block (``block``). Where the tray
is, from points: the drawer's axis is the horizontal direction from the body to the drawer front (as in the
``drawer`` family); the tray lies behind the handle along it. From ``sim/assets/drawer_cabinet.urdf``: the handle's
centre is 5 cm ahead of the tray's inside front face and the tray is 21 cm deep inside, 22.4 cm wide inside; the
cabinet's front face is 13 cm ahead of its centre; the handle is 8 cm above the table and the tray's walls end
2 cm lower. The block is a 4 cm cube.

Recovery by the failed constraint's id prefix:

=============================================== ===========================================================
failed                                          next subgoal
=============================================== ===========================================================
drawerstill, handlegrip, jawshut, handled,       grasp the handle again (then pull again)
pulled (in a pull)
drawerfreed (still holding the handle)           pull again (it ends by letting go)
steady, grasped, lifted, gripped, carriedin,     grasp the block again where it is now (then put it in)
overtray, intray
freed (still holding the block)                  put it in again (it ends by letting go)
=============================================== ===========================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice, whole
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name
from code_as_monitor.vlm.kb.shared.feedback import failed_kind
from code_as_monitor.vlm.kb.shared.grip import FINGER_LEFT, FINGER_RIGHT, GRIP_TIP, in_gripper, part_spec
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

PUT_OPEN = 0.10
"""Metres the drawer must come out for the block: the 4 cm block plus 3 cm either side for a drop that is a
little off (the open part of the tray is what the drawer came out)."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # handle grasp, as the drawer family's (vlm/kb/families/drawer.py, where the reasons are): the handle stays
    # put (2 cm) while the jaws close; its centre within 3 cm of the grasp point; the jaws closed on the 1.2 cm
    # bar, 1 to 5 cm apart (open 8 cm, on nothing 0).
    "put_still": {"max_disp": 0.02},
    "put_handle_grip": {"max_dist": 0.03},
    "put_jaw_shut": {"min_jaw": 0.01, "max_jaw": 0.05},
    # pull, upon: released, the grasp point 6 cm from the handle (as the drawer family's).
    "put_pull_freed": {"release_dist": 0.06},
    # pull, during / upon: as the drawer family's, with PUT_OPEN (see above).
    "put_handled": {"max_dist": 0.03, "min_open": PUT_OPEN},
    "put_pulled": {"min_open": PUT_OPEN},
    # block grasp: during (proactive) it stays where it lies until it is between the fingers (2 cm: the jaws
    # close 3 cm either side of a 4 cm block's centre at most); upon, its centre within 3 cm of the grasp
    # point and risen 5 cm with it (the grasp lifts it to 20 cm).
    "put_steady": {"max_disp": 0.02, "max_dist": 0.03},
    "put_lifted": {"max_dist": 0.03, "min_rise": 0.05},
    # put_in, during: the block stays within 4 cm of the grasp point until it is inside the tray.
    # Geometry of the tray from the URDF (see the module docstring): behind the handle along the drawer's axis
    # by 7 to 24 cm (the block's centre: 5 cm to the tray's inside front face + 2 cm half block; 26 cm to the
    # back wall's inside - 2 cm), within 9 cm of the axis sideways (11.2 cm - 2 cm), and not above the handle's
    # height by more than 5 cm (a block in the tray has its centre 4 cm lower; one released 5 cm above it falls in),
    # and its centre ahead of the cabinet's front face (13 cm ahead of the cabinet's centre): one on the cabinet's
    # top is behind that face (its centre 4 cm above the handle would pass the height test alone).
    "carriedin": {"max_dist": 0.04, "back_min": 0.07, "back_max": 0.24, "half_width": 0.09, "above_max": 0.05,
                  "face": 0.13},
    # put_in, during (proactive): once the block's centre is lower than 3.5 cm above the handle (its bottom at the
    # height of the cabinet's top, 2 cm above the handle: about to touch it), it is over the OPEN part of the
    # tray: 7 cm behind the handle or more, and its centre ahead of the cabinet's front face (13 cm ahead of the
    # cabinet's centre; a block whose centre is over the tray tips into it: in the benchmark one dropped with its
    # centre 2 cm from the face landed inside); sideways as above. Over the cabinet's top or the drawer's front
    # plate, it lands outside. Not higher: a noisy grasp carries the block as low as 4.3 cm above the handle
    # beside the drawer (benchmark, rlb-put-in-drawer), which must not count as landing.
    "overtray": {"approach": 0.035, "back_min": 0.07, "face": 0.13, "half_block": 0.0, "half_width": 0.09},
    "intray": {"back_min": 0.07, "back_max": 0.24, "half_width": 0.09, "above_max": 0.05, "face": 0.13},
    # put_in, upon: the gripper has let go and moved 6 cm away from the block's centre.
    "put_freed": {"release_dist": 0.06},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


PULL_DISTANCE = 0.17
"""The pull of the ``drawer`` family (its 15 cm opening plus 2 cm): more than the block needs, as a learned policy
would pull."""


def grasp_handle(cab: str) -> list[dict[str, Any]]:
    """``grasp`` the handle, as the drawer family's (same ids, so the same check templates): during (proactive) the
    handle stays put; upon, it is at the grasp point and the jaws are closed."""
    st, gr, js = _thr("put_still"), _thr("put_handle_grip"), _thr("put_jaw_shut")
    handle = part_spec(cab, "handle", "point", "handle")
    return [
        constraint(f"drawerstill_{cab}", f"the handle of {nice(cab)} stays where it is (within {st['max_disp'] * 100:.0f} "
                   "cm) while the gripper approaches and closes; if the drawer moves, the jaws close on nothing",
                   "during", True, st, [handle]),
        constraint(f"handlegrip_{cab}", f"the handle of {nice(cab)} is between the fingers: its centre within "
                   f"{gr['max_dist'] * 100:.0f} cm of the grasp point", "upon", False, gr, [GRIP_TIP, handle]),
        constraint(f"jawshut_{cab}", f"the gripper's jaws are closed on the handle of {nice(cab)}: their opening "
                   f"between {js['min_jaw'] * 100:.1f} and {js['max_jaw'] * 100:.0f} cm", "upon", False, js,
                   [FINGER_LEFT, FINGER_RIGHT]),
    ]


@dataclass(frozen=True)
class PutGoal:
    """The cabinet and the item that goes into its drawer."""

    cabinet: str
    item: str


VERBS = ("open", "pull", "put", "insert", "drop", "stow", "grasp", "pick")
MODIFIERS = ("open", "out", "in")
HEADS = ("drawer", "cabinet", "handle", "block", "item")
DOING = "opens the drawer, then puts the block in it"


def claims(ins: Instruction) -> bool:
    return bool({"drawer", "cabinet"} & ins.heads) and bool({"block", "item"} & ins.heads)


def understand(ins: Instruction, objects: list[str]) -> PutGoal | None:
    """The cabinet and the block grounded on ``objects``; None when the instruction is not about putting an item
    into the drawer."""
    if not claims(ins):
        return None
    r = Reading(ins, "put-in-drawer", heads=HEADS, verbs=VERBS)
    r.verbs(VERBS, DOING)
    r.modifiers(MODIFIERS, DOING)
    if not {"put", "insert", "drop", "stow"} & set(ins.verbs):
        r.refuse("say what to do with the block: put it in the drawer")
    for p in r.phrases(lambda p: p.head in HEADS):
        q = ins.resolve(p.index)
        if q.position or q.ordinal or (q.quantity is not None and q.quantity.value != 1):
            r.refuse(f"{p.text!r}: the scene has one drawer and one block")
        if q.colour and q.head in ("drawer", "cabinet", "handle"):
            r.refuse(f"{p.text!r}: the scene has one drawer")
        r.use(p.index)
    into = [k for k in ins.links if k.kind in ("into", "to") and ins.resolve(k.b).head in ("drawer", "cabinet")]
    # "open the drawer and put the block inside (in)": the particle names the drawer just opened, the one container
    inside = "in" in ins.modifiers and any(ins.resolve(p.index).head in ("drawer", "cabinet") for p in ins.phrases)
    if not into and not inside:
        r.refuse("say where the block goes: into the drawer")
    for k in ins.links:
        a = ins.resolve(k.a).head if k.a is not None else ""
        b = ins.resolve(k.b).head
        if k in into or (k.kind == "of" and a in ("handle", "drawer") and b in ("drawer", "cabinet")) or (
                k.kind in ("by", "with", "at") and b == "handle") or (k.kind == "from" and b == "table"):
            r.use_link(k)
            r.use(k.b)
    names = scene_names(objects)
    cabinet = next((o for o in names if "drawer" in o or "cabinet" in o), "")
    items = [o for o in names if o not in (cabinet, "table")]
    colours = {ins.resolve(p.index).colour for p in r.phrases(lambda p: p.head in ("block", "item"))} - {""}
    if colours:
        items = [o for o in items if any(c in o for c in colours)]
    if not cabinet:
        r.refuse("the scene has no drawer")
    if len(items) != 1:
        r.refuse("the scene should have one block to put away")
    r.finish()
    return PutGoal(cabinet, items[0])


def scene(ins: Instruction) -> list[str] | None:
    """The put-in-drawer scene's objects, or None."""
    return ["drawer_cabinet", "block", "table"] if claims(ins) else None


# --- constraint builders -----------------------------------------------------------------------------------
def _tray(cab: str) -> list[dict[str, str]]:
    return [part_spec(cab, "handle", "point", "handle"), part_spec(cab, "drawer", "point", "drawer front"),
            part_spec(cab, "frame", "point", "frame")]


def pull(cab: str) -> list[dict[str, Any]]:
    """``pull``: the drawer family's checks with ``PUT_OPEN``."""
    hd, pu, fr = _thr("put_handled"), _thr("put_pulled"), _thr("put_pull_freed")
    h, f, b = _tray(cab)
    return [
        constraint(f"handled_{cab}", f"the handle of {nice(cab)} stays in the gripper (within {hd['max_dist'] * 100:.0f} "
                   f"cm of the grasp point) until the drawer is out {hd['min_open'] * 100:.0f} cm", "during", False, hd,
                   [GRIP_TIP, h, f, b]),
        constraint(f"pulled_{cab}", f"the drawer of {nice(cab)} came out at least {pu['min_open'] * 100:.0f} cm along its "
                   f"axis since the pull began: room for the block", "upon", False, pu, [h, f, b]),
        constraint(f"drawerfreed_{cab}", f"the handle of {nice(cab)} is released: the grasp point at least "
                   f"{fr['release_dist'] * 100:.0f} cm from it", "upon", False, dict(fr), [GRIP_TIP, h]),
    ]


def grasp_item(item: str) -> list[dict[str, Any]]:
    """The block's grasp: it stays put until gripped (proactive); then it is gripped and lifted."""
    st, li = _thr("put_steady"), _thr("put_lifted")
    return [
        constraint(f"steady_{item}", f"{nice(item)} stays where it lies (within {st['max_disp'] * 100:.0f} cm) until it "
                   f"is between the fingers", "during", True, st, [GRIP_TIP, whole(item)]),
        *in_gripper(item, whole(item), li),
    ]


def put_in(item: str, cab: str) -> list[dict[str, Any]]:
    """``put_in``: during, carried until inside; proactive, over the open part of the tray when low; upon, inside
    the tray and released."""
    ca, ov, it, fr = _thr("carriedin"), _thr("overtray"), _thr("intray"), _thr("put_freed")
    tray = _tray(cab)
    return [
        constraint(f"carriedin_{item}", f"{nice(item)} stays in the gripper (within {ca['max_dist'] * 100:.0f} cm of the "
                   f"grasp point) until it is inside the drawer of {nice(cab)}", "during", False, ca,
                   [GRIP_TIP, whole(item), *tray]),
        constraint(f"overtray_{item}", f"once {nice(item)} is lower than {ov['approach'] * 100:.0f} cm above the handle of "
                   f"{nice(cab)}, it is over the open part of the drawer (behind the drawer front, ahead of the "
                   f"cabinet's front face, within {ov['half_width'] * 100:.0f} cm of the drawer's axis)", "during", True,
                   ov, [whole(item), *tray]),
        constraint(f"intray_{item}", f"{nice(item)} is inside the drawer of {nice(cab)}: {it['back_min'] * 100:.0f} to "
                   f"{it['back_max'] * 100:.0f} cm behind the handle along the drawer's axis, within "
                   f"{it['half_width'] * 100:.0f} cm of it sideways, ahead of the cabinet's front face, at most "
                   f"{it['above_max'] * 100:.0f} cm above the handle", "upon", False, it,
                   [whole(item), *tray]),
        constraint(f"freed_{item}", f"{nice(item)} is released: the grasp point at least {fr['release_dist'] * 100:.0f} cm "
                   f"from it", "upon", False, fr, [GRIP_TIP, whole(item)]),
    ]


# --- templates --------------------------------------------------------------------------------------------
def _where(x: int, h: int, dr: int, fr: int, face: str) -> str:
    """Lines computing ``axis`` (3,), ``back`` (metres behind the handle along it), ``side`` (metres off it) and
    ``above`` (metres above the handle) of element ``x``'s centre, and ``opened`` (metres from the handle back to
    the cabinet's front face, ``face`` ahead of the frame's centre)."""
    return f"""
    axis = centroid(E[{dr}]) - centroid(E[{fr}])
    axis = np.array([axis[0], axis[1], 0.0]) / (np.linalg.norm(axis[:2]) + 1e-9)
    rel = centroid(E[{x}]) - centroid(E[{h}])
    back = -np.dot(rel, axis)
    side = np.abs(rel[0] * axis[1] - rel[1] * axis[0])
    above = rel[2]
    opened = np.dot(centroid(E[{h}]) - centroid(E[{fr}]), axis) - {face}
"""


def _inside_expr(th: dict[str, float]) -> tuple[str, str]:
    """(condition, margin) of "inside the tray" over ``back``, ``side``, ``above``."""
    bmin, bmax, hw, am = num(th["back_min"]), num(th["back_max"]), num(th["half_width"]), num(th["above_max"])
    cond = f"back >= {bmin} and back <= {bmax} and back <= opened and side <= {hw} and above <= {am}"
    margin = f"np.min([back - {bmin}, {bmax} - back, opened - back, {hw} - side, {am} - above])"
    return cond, margin


def intray(c: Spec) -> str:
    """Parts: [item, handle, drawer front, frame] (points). The item's centre is inside the drawer's tray."""
    x, h, dr, fr = c["element_ids"][:4]
    xn, cn = obj_name(c, 0), obj_name(c, 1)
    cond, margin = _inside_expr(c["thresholds"])
    body = _where(x, h, dr, fr, num(c["thresholds"]["face"])) + f"""
    margin = {margin}
    if {cond}:
        return True, {lit(xn + " is inside the drawer of " + cn + " (%.3f m behind the handle, %.3f m off the axis, %.3f m above the handle)")} % (back, side, above), margin
    return False, {lit(xn + " is not inside the drawer of " + cn + ": %.3f m behind the handle, %.3f m off the axis, %.3f m above the handle")} % (back, side, above), margin
"""
    return check_fn(c, body)


def carriedin(c: Spec) -> str:
    """Parts: [tip, item, handle, drawer front, frame] (points). The item is at the grasp point, unless it is
    already inside the tray (it was let go there)."""
    tip, x, h, dr, fr = c["element_ids"][:5]
    xn = obj_name(c, 1)
    md = num(c["thresholds"]["max_dist"])
    cond, margin = _inside_expr(c["thresholds"])
    body = _where(x, h, dr, fr, num(c["thresholds"]["face"])) + f"""
    d = distance(E[{tip}], centroid(E[{x}]))
    margin = np.max([{md} - d, {margin}])
    if d <= {md} or ({cond}):
        return True, {lit(xn + " is in the gripper or already in the drawer (%.3f m from the grasp point)")} % d, margin
    return False, {lit(xn + " dropped: it is %.3f m from the grasp point and not inside the drawer")} % d, margin
"""
    return check_fn(c, body)


def overtray(c: Spec) -> str:
    """Parts: [item, handle, drawer front, frame] (points). Low means over the open part of the tray."""
    x, h, dr, fr = c["element_ids"][:4]
    th, xn = c["thresholds"], obj_name(c, 0)
    ap, bmin, face, hb, hw = (num(th[k]) for k in ("approach", "back_min", "face", "half_block", "half_width"))
    body = _where(x, h, dr, fr, face) + f"""
    margin = np.max([above - {ap}, np.min([back - {bmin}, opened - {hb} - back, {hw} - side])])
    if above >= {ap} or (back >= {bmin} and back <= opened - {hb} and side <= {hw}):
        return True, {lit(xn + " is over the open drawer or still high (%.3f m behind the handle of an opening %.3f m long, %.3f m off the axis, %.3f m above the handle)")} % (back, opened, side, above), margin
    return False, {lit(xn + " is low (%.3f m above the handle) but not over the open drawer: %.3f m behind the handle of an opening %.3f m long, %.3f m off the axis; it will land outside")} % (above, back, opened, side), margin
"""
    return check_fn(c, body)


# --- the rule ----------------------------------------------------------------------------------------------
REGRASP_HANDLE = ("drawerstill", "handlegrip", "jawshut", "handled", "pulled")
REGRASP_ITEM = ("steady", "grasped", "lifted", "gripped", "carriedin", "overtray", "intray")


def next_subgoal(goal: PutGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    cab, item = goal.cabinet, goal.item
    gh = answer(f"grasp the handle of {nice(cab)}", "grasp", {"obj": cab, "part": "handle"}, grasp_handle(cab), "")
    p = answer(f"pull the drawer of {nice(cab)} open by {PULL_DISTANCE * 100:.0f} cm", "pull",
               {"obj": cab, "distance": PULL_DISTANCE}, pull(cab), "")
    gi = answer(f"grasp {nice(item)}", "grasp", {"obj": item}, grasp_item(item), "")
    pi = answer(f"put {nice(item)} into the drawer of {nice(cab)}", "put_in", {"obj": item, "target": cab},
                put_in(item, cab), "")
    skill = ((previous or {}).get("action") or {}).get("skill")
    args = ((previous or {}).get("action") or {}).get("args") or {}
    if not previous or skill not in ("grasp", "pull", "put_in"):
        if previous and previous.get("done"):
            return done("the block is in the drawer")
        gh["reasoning"] = "the drawer is closed: grasp its handle, pull it open, then put the block in"
        return gh
    kind = failed_kind(feedback)
    on_item = args.get("obj") == item
    if kind == "success":
        if skill == "grasp" and not on_item:
            p["reasoning"] = "the handle is held; pull the drawer out (it lets go at the end)"
            return p
        if skill == "pull":
            gi["reasoning"] = "the drawer is open; grasp the block"
            return gi
        if skill == "grasp":
            pi["reasoning"] = "the block is held; lower it into the open drawer and let go"
            return pi
        return done("the block is in the drawer")
    if kind in REGRASP_HANDLE or (skill in ("grasp", "pull") and not on_item and kind not in ("drawerfreed",)):
        gh["reasoning"] = f"the handle is not in the gripper or the drawer is not open enough ({kind}); grasp it again"
        return gh
    if kind == "drawerfreed":
        p["reasoning"] = "the handle is still held after the pull; pull again, which ends by letting go"
        return p
    if kind in REGRASP_ITEM or (skill == "grasp" and kind == "other"):
        gi["reasoning"] = f"the block is not held or not in the drawer ({kind}); grasp it again where it is now"
        return gi
    pi["reasoning"] = f"the block is still held ({kind}); put it in again, which ends by letting go"
    return pi


FAMILY = TaskFamily(
    name="putdrawer",
    task="put-in-drawer",
    summary="open the drawer, then put the block in it",
    example="open the drawer and put the block in it",
    understand=understand,
    next_subgoal=next_subgoal,
    scene=scene,
    thresholds=THRESHOLDS,
    templates={"carriedin": carriedin, "overtray": overtray, "intray": intray},
)
