# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""kb family ``dustpan`` (task ``sweep-to-dustpan``): sweep the dirt into the dustpan with the broom.

Plan: ``grasp`` the broom by its handle -> ``sweep`` (the skill turns the broom so its head faces the dustpan,
lowers the head behind the dirt and pushes it into the pan, then lifts it) -> done.

Elements: the grasp point (``robot/tip``, point), the broom's handle (``broom/handle``, point), the pan's floor
(``dustpan/pan``, a SURFACE: its corners), and every dirt piece the scene lists (``dirt_0`` ... , points).

Recovery by the failed constraint's id prefix: ``steady``, ``grasped``, ``lifted``, ``gripped`` (the broom is not
held) -> grasp the broom again, then sweep; ``inpan`` (dirt left outside) -> sweep again (the broom is still held).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from code_as_monitor.vlm.grammar import Instruction
from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared.answer import answer, constraint, done, nice, whole
from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name
from code_as_monitor.vlm.kb.shared.feedback import failed_kind
from code_as_monitor.vlm.kb.shared.grip import GRIP_TIP, in_gripper, part_spec, still_gripped
from code_as_monitor.vlm.kb.shared.reading import Reading, scene_names

IN_PAN = 0.8
"""The fraction of the dirt that must end up in the pan (4 of 5): a sweep that leaves a crumb behind is done."""

THRESHOLDS: dict[str, dict[str, float]] = {
    # From sim/assets: the broom's handle is 24 cm long and 1.6 cm thick; the pan's floor 14 x 18 cm; the dirt
    # pieces 2 cm cubes. grasp: the broom stays put until gripped (2 cm); upon, its handle at the grasp point
    # (3 cm) and risen 5 cm with it.
    "pan_steady": {"max_disp": 0.02, "max_dist": 0.03},
    "pan_lifted": {"max_dist": 0.03, "min_rise": 0.05},
    # sweep, during: the handle stays within 4 cm of the grasp point.
    "pan_gripped": {"max_dist": 0.04},
    # sweep, upon: at least IN_PAN of the dirt pieces over the pan's floor, counted inside its outline shrunk
    # 1 cm towards its centre (a piece half over the lip is not in), and below 3 cm (on the floor, not on the
    # broom's head).
    "inpan": {"min_fraction": IN_PAN, "shrink": 0.01, "max_height": 0.03},
}


def _thr(kind: str) -> dict[str, float]:
    return dict(THRESHOLDS[kind])


@dataclass(frozen=True)
class SweepGoal:
    """The broom, the dustpan and the dirt pieces."""

    broom: str
    pan: str
    dirt: tuple[str, ...]


VERBS = ("sweep", "push", "put", "use", "grasp")
MODIFIERS = ("in", "up", "all")
HEADS = ("dirt", "dustpan", "broom")
DOING = "sweeps the dirt into the dustpan with the broom"


def claims(ins: Instruction) -> bool:
    return bool({"dirt", "dustpan"} & ins.heads)


def understand(ins: Instruction, objects: list[str]) -> SweepGoal | None:
    """The broom, dustpan and dirt grounded on ``objects``; None when the instruction is not about sweeping
    dirt into a dustpan."""
    if not claims(ins):
        return None
    r = Reading(ins, "sweep-to-dustpan", heads=HEADS, verbs=VERBS)
    r.verbs(VERBS, DOING)
    r.modifiers(MODIFIERS, DOING)
    if not {"sweep", "push", "put"} & set(ins.verbs):
        r.refuse("say what to do with the dirt: sweep it into the dustpan")
    for p in r.phrases(lambda p: p.head in HEADS):
        q = ins.resolve(p.index)
        if q.position or q.ordinal or q.colour:
            r.refuse(f"{p.text!r}: the kb sweeps all the dirt into the one dustpan")
        if q.quantity is not None and q.quantity.kind not in ("all",):
            r.refuse(f"{p.text!r}: the kb sweeps all the dirt, not a part of it")
        r.use(p.index)
    into = [k for k in ins.links if k.kind in ("into", "to", "on") and ins.resolve(k.b).head == "dustpan"]
    if not into:
        r.refuse("say where the dirt goes: into the dustpan")
    for k in ins.links:
        if k in into or (k.kind == "with" and ins.resolve(k.b).head == "broom"):
            r.use_link(k)
    names = scene_names(objects)
    broom = next((o for o in names if "broom" in o or "brush" in o), "")
    pan = next((o for o in names if "dustpan" in o), "")
    dirt = tuple(o for o in names if o.startswith("dirt"))
    if not (broom and pan and dirt):
        r.refuse("the scene needs a broom, a dustpan and dirt")
    r.finish()
    return SweepGoal(broom, pan, dirt)


def scene(ins: Instruction) -> list[str] | None:
    """The sweep-to-dustpan scene's objects, or None."""
    return ["broom", "dustpan", *(f"dirt_{i}" for i in range(5)), "table"] if claims(ins) else None


# --- constraint builders -----------------------------------------------------------------------------------
def _handle(broom: str) -> dict[str, str]:
    return part_spec(broom, "handle", "point", "handle")


def _floor(pan: str) -> dict[str, str]:
    return part_spec(pan, "pan", "surface", "floor")


def grasp(g: SweepGoal) -> list[dict[str, Any]]:
    """``grasp`` the broom: it stays put until gripped (proactive), then it is gripped and lifted."""
    st, li = _thr("pan_steady"), _thr("pan_lifted")
    return [
        constraint(f"steady_{g.broom}", f"{nice(g.broom)} stays where it lies (within {st['max_disp'] * 100:.0f} cm) "
                   f"until its handle is between the fingers", "during", True, st, [GRIP_TIP, _handle(g.broom)]),
        *in_gripper(g.broom, _handle(g.broom), li),
    ]


def sweep(g: SweepGoal) -> list[dict[str, Any]]:
    """``sweep``: during, the broom stays gripped; upon, most of the dirt is in the pan."""
    gr, ip = _thr("pan_gripped"), _thr("inpan")
    need = int(-(-IN_PAN * len(g.dirt) // 1))
    return [
        still_gripped(g.broom, _handle(g.broom), gr),
        constraint(f"inpan_{g.pan}", f"at least {need} of the {len(g.dirt)} dirt pieces are in {nice(g.pan)}: over its "
                   f"floor, {ip['shrink'] * 100:.0f} cm inside its edges", "upon", False, ip,
                   [_floor(g.pan), *(whole(d) for d in g.dirt)]),
    ]


# --- templates ---------------------------------------------------------------------------------------------
def inpan(c: Spec) -> str:
    """Parts: [pan floor (surface), dirt pieces (points)...]. At least ``min_fraction`` of them over the floor's
    outline shrunk by ``shrink`` and below ``max_height`` above it."""
    ids = c["element_ids"]
    fl, dirt = ids[0], ids[1:]
    th, pn = c["thresholds"], obj_name(c, 0)
    fr, sh, mh = num(th["min_fraction"]), num(th["shrink"]), num(th["max_height"])
    pts = ", ".join(f"centroid(E[{i}])" for i in dirt)
    body = f"""
    poly = E[{fl}]
    mid = centroid(poly)
    r = np.linalg.norm(poly[:, :2] - mid[:2], axis=1)
    inner = mid + (poly - mid) * np.maximum(0.0, 1.0 - {sh} / (r + 1e-9))[:, None]
    dirt = np.array([{pts}])
    low = dirt[dirt[:, 2] - mid[2] <= {mh}]
    n = count_in_polygon(low, inner)
    need = math.ceil({fr} * {len(dirt)} - 1e-9)
    if n >= need:
        return True, {lit("%d of " + str(len(dirt)) + " dirt pieces are in " + pn)} % n, float(n - need) + 0.5
    return False, {lit("only %d of " + str(len(dirt)) + " dirt pieces are in " + pn + " (needs %d)")} % (n, need), float(n - need) + 0.5
"""
    return check_fn(c, body)


# --- the rule ----------------------------------------------------------------------------------------------
def next_subgoal(goal: SweepGoal, previous: dict[str, Any] | None, feedback: str | None) -> dict[str, Any]:
    g = answer(f"grasp {nice(goal.broom)} by its handle", "grasp", {"obj": goal.broom, "part": "handle"}, grasp(goal),
               "")
    s = answer(f"sweep the dirt into {nice(goal.pan)} with {nice(goal.broom)}", "sweep",
               {"obj": goal.broom, "target": goal.pan}, sweep(goal), "")
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in ("grasp", "sweep"):
        if previous and previous.get("done"):
            return done("the dirt is in the dustpan")
        g["reasoning"] = "grasp the broom, then sweep the dirt into the dustpan with its head"
        return g
    kind = failed_kind(feedback)
    if kind == "success":
        if skill == "grasp":
            s["reasoning"] = "the broom is held; put its head behind the dirt and push the dirt into the pan"
            return s
        return done("the dirt is in the dustpan")
    if kind == "inpan":
        s["reasoning"] = "dirt is left outside the pan; sweep again (the broom is still held)"
        return s
    g["reasoning"] = f"the broom is not held ({kind}); grasp it again, then sweep"
    return g


FAMILY = TaskFamily(
    name="dustpan",
    task="sweep-to-dustpan",
    summary="sweep the dirt into the dustpan with the broom",
    example="sweep the dirt into the dustpan",
    understand=understand,
    next_subgoal=next_subgoal,
    scene=scene,
    thresholds=THRESHOLDS,
    templates={"inpan": inpan},
)
