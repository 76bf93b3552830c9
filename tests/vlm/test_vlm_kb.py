"""The kb backend: valid plans and programs for the simulator's tasks, through the VLM-path validators."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core import Element
from code_as_monitor.core.errors import VLMError
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check, legend_specs
from code_as_monitor.vlm.backend import KBBackendConfig, make_backend
from code_as_monitor.vlm.grammar import parse
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.families.stack_goal import understand as stack_understand
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.registry import all_thresholds
from code_as_monitor.vlm.kb.shared.feedback import classify

STACK = "stack the blocks: red at the bottom, then green, then blue"
SWEEP = "sweep half of the blocks into the zone"
ROPE = "use the rope to close the opening of the square"
OTHERS = {("red_block", ""): [0.4, 0.2, 0.02], ("blue_block", ""): [0.6, -0.2, 0.02]}
"""The blocks a pick does not take, on the table away from it (its clear-the-top checks read them)."""
IMG = {"front": np.zeros((8, 8, 3), np.uint8), "top": np.zeros((8, 8, 3), np.uint8)}


def gen_coder():
    be = make_backend(KBBackendConfig())
    gen = ConstraintGenerator(be)
    return gen, MonitorCoder(be, usage=gen.usage)


def program_for(coder, subgoal, make_elements, points):
    els = make_elements(subgoal, points)
    return coder.write_program(subgoal, els, IMG, basic_check([c.id for c in subgoal.constraints])), els


def test_stack_plan_with_success_feedback():
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    assert objs == ["red_block", "green_block", "blue_block", "table"]
    prev, actions = None, []
    for _ in range(8):
        sg = gen.next_subgoal(STACK, IMG, objs, prev, "success" if prev else None)
        if sg.done:
            break
        actions.append((sg.action.skill, sg.action.args))
        prev = sg
    assert actions == [
        ("pick", {"obj": "green_block"}),
        ("place_on", {"obj": "green_block", "target": "red_block"}),
        ("pick", {"obj": "blue_block"}),
        ("place_on", {"obj": "blue_block", "target": "green_block"}),
    ]
    assert sg.done and sg.constraints == []
    assert gen.usage.calls == 5 and gen.usage.episode()["subgoals"] == 5


def test_stack_constraints_phases_and_parts():
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    pick = gen.next_subgoal(STACK, IMG, objs)
    [held] = pick.constraints
    assert held.phase.value == "upon" and not held.proactive
    parts = [(p.obj, p.part, p.kind.value) for p in held.parts]
    assert parts == [("robot", "tip", "point"), ("green_block", "", "point")]
    place_blue = gen.next_subgoal(STACK, IMG, objs, _subgoal(gen, objs, 2), "success")
    by_id = {c.id: c for c in place_blue.constraints}
    assert by_id["attached_blue_block"].phase.value == "during" and not by_id["attached_blue_block"].proactive
    assert by_id["still_green_block"].proactive
    cen = by_id["centred_blue_block_on_green_block"]
    assert cen.phase.value == "upon" and cen.proactive
    assert cen.thresholds["max_offset"] == pytest.approx(all_thresholds()["centred"]["max_offset"])
    assert "tower_green_block_on_red_block" in by_id


def _subgoal(gen, objs, n):
    """The n-th subgoal (0-based) of the success path."""
    prev = None
    for _ in range(n + 1):
        prev = gen.next_subgoal(STACK, IMG, objs, prev, "success" if prev else None)
    return prev


@pytest.mark.parametrize(
    ("feedback", "skill", "obj"),
    [
        ("failed: attached_green_block: green_block dropped: detached from the suction cup", "pick", "green_block"),
        ("green_block is offset 0.021 m from the centre of red_block: stacking on it will topple", "pick",
         "green_block"),
        # the block below was pushed while green was on its way down: green is still on the cup, place it again
        ("red_block moved 0.030 m: the tower below is disturbed", "place_on", "green_block"),
        ("green_block is still held by the suction cup on red_block", "place_on", "green_block"),
        ("something unexpected", "place_on", "green_block"),
    ],
)
def test_stack_recovery_after_place_green(feedback, skill, obj):
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    place_green = _subgoal(gen, objs, 1)
    nxt = gen.next_subgoal(STACK, IMG, objs, place_green, feedback)
    assert (nxt.action.skill, nxt.action.args["obj"]) == (skill, obj)


def test_stack_collapse_while_placing_blue_sets_blue_down_then_restarts_from_green():
    """Blue may still be on the suction cup, and a cup holding blue cannot pick green: blue goes down on free
    table first; the set-down names the level to rebuild from, which the next (stateless) call reads."""
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    place_blue = _subgoal(gen, objs, 3)
    fb = "green_block is no longer on red_block (height difference 0.001 m): the tower collapsed"
    aside = gen.next_subgoal(STACK, IMG, objs, place_blue, fb)
    assert aside.action.to_dict() == {"skill": "place_on", "args": {"obj": "blue_block", "target": "table"}}
    assert [c.id for c in aside.constraints] == ["released_blue_block"]
    for outcome in ("success", "failure: released_blue_block: blue_block is still held by the suction cup"):
        nxt = gen.next_subgoal(STACK, IMG, objs, aside, outcome)
        assert nxt.action.to_dict() == {"skill": "pick", "args": {"obj": "green_block"}}
    fb = "blue_block dropped: detached from the suction cup (0.200 m from the tip) before resting on green_block"
    assert gen.next_subgoal(STACK, IMG, objs, place_blue, fb).action.args == {"obj": "blue_block"}


def test_stack_pick_watches_the_tower_built_so_far():
    """Picking level 2 (blue) has green-on-red as a during check: a cup reaching for a block that lies against
    the tower can knock green off, or lift it instead. Picking level 1 has no tower to watch."""
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    pick_green, pick_blue = _subgoal(gen, objs, 0), _subgoal(gen, objs, 2)
    assert [c.id for c in pick_green.constraints] == ["held_green_block"]
    by_id = {c.id: c for c in pick_blue.constraints}
    assert set(by_id) == {"held_blue_block", "tower_green_block_on_red_block", "plumb_green_block_on_red_block"}
    tower = by_id["tower_green_block_on_red_block"]
    assert tower.phase.value == "during" and not tower.proactive
    assert [(p.obj, p.kind.value) for p in tower.parts] == [("green_block", "point"), ("red_block", "point")]


def test_stack_collapse_while_picking_blue_sets_down_what_the_cup_may_hold_then_restarts_from_green():
    """The cup may hold blue (or green, lifted off the tower instead of blue) when the collapse is seen: whatever
    it holds goes down on free table before green is picked again."""
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    pick_blue = _subgoal(gen, objs, 2)
    fb = "green_block is no longer on red_block (offset 0.006 m, height difference 0.095 m): the tower collapsed"
    aside = gen.next_subgoal(STACK, IMG, objs, pick_blue, fb)
    assert aside.action.to_dict() == {"skill": "place_on", "args": {"obj": "blue_block", "target": "table"}}
    nxt = gen.next_subgoal(STACK, IMG, objs, aside, "success")
    assert nxt.action.to_dict() == {"skill": "pick", "args": {"obj": "green_block"}}


def test_failed_pick_picks_again():
    gen, _ = gen_coder()
    objs = infer_objects(STACK)
    pick = gen.next_subgoal(STACK, IMG, objs)
    nxt = gen.next_subgoal(STACK, IMG, objs, pick, "green_block is not held by the suction cup: 0.090 m from the tip")
    assert nxt.action.to_dict() == {"skill": "pick", "args": {"obj": "green_block"}}


def test_feedback_categories():
    assert classify(None) == "success" and classify("success") == "success"
    assert classify("subgoal completed") == "success"
    assert classify("X is not held") == "dropped"
    assert classify("X is offset 0.02 m") == "offset"
    assert classify("the tower collapsed") == "collapse"


def test_tower_order_reads_colours_in_order():
    objs = ["blue_block", "red_block", "green_block"]

    def tower(text: str) -> tuple[str, ...]:
        return stack_understand(parse(text), objs).tower

    assert tower("stack: blue at the bottom, then red, then green") == ("blue_block", "red_block", "green_block")
    assert tower("stack green on red, blue on top") == ("red_block", "green_block", "blue_block")


# --- programs on constructed states --------------------------------------------------------------


def test_pick_program_verdicts(make_elements, run_program, history_of):
    gen, coder = gen_coder()
    sg = gen.next_subgoal(STACK, IMG, infer_objects(STACK))
    start = make_elements(sg, {**OTHERS, ("robot", "tip"): [0.3, -0.3, 0.3], ("green_block", ""): [0.5, 0, 0.02]})
    held = {**OTHERS, ("robot", "tip"): [0.5, 0, 0.12], ("green_block", ""): [0.5, 0, 0.10]}
    src, els = program_for(coder, sg, make_elements, held)
    ok, reason, margin = run_program(src, els, history_of(start, els))["held_green_block"]
    assert ok is True and margin > 0
    on_table = make_elements(sg, {**OTHERS, ("robot", "tip"): [0.5, 0, 0.12], ("green_block", ""): [0.5, 0, 0.02]})
    ok, reason, margin = run_program(src, on_table, history_of(start, on_table))["held_green_block"]
    assert ok is False and "not held" in reason and margin < 0
    assert classify(reason) == "dropped"


def test_a_block_resting_on_the_tower_under_a_hovering_cup_is_not_held(make_elements, run_program, history_of):
    """The bug behind the placement-noise loops: green sits on red (high) and the cup hovers on it (close), but
    nothing was picked: it has not risen since the pick began."""
    gen, coder = gen_coder()
    sg = gen.next_subgoal(STACK, IMG, infer_objects(STACK))
    resting = {**OTHERS, ("robot", "tip"): [0.5, 0, 0.085], ("green_block", ""): [0.505, 0, 0.06]}
    src, els = program_for(coder, sg, make_elements, resting)
    start = make_elements(sg, {**OTHERS, ("robot", "tip"): [0.3, -0.3, 0.3], ("green_block", ""): [0.505, 0, 0.06]})
    ok, reason, margin = run_program(src, els, history_of(start, els))["held_green_block"]
    assert ok is False and margin < 0 and classify(reason) == "dropped"
    lifted = make_elements(sg, {**OTHERS, ("robot", "tip"): [0.5, 0, 0.13], ("green_block", ""): [0.5, 0, 0.105]})
    assert run_program(src, lifted, history_of(start, lifted))["held_green_block"][0] is True


def _place_state(x_xyz, tip_xyz, target_xyz=(0.5, 0.0, 0.02)):
    return {("robot", "tip"): tip_xyz, ("green_block", ""): x_xyz, ("red_block", ""): target_xyz}


def test_place_program_verdicts(make_elements, run_program, history_of):
    gen, coder = gen_coder()
    objs = infer_objects(STACK)
    sg = _subgoal(gen, objs, 1)
    carried = make_elements(sg, _place_state([0.4, 0.1, 0.14], [0.4, 0.1, 0.165]))
    upon = ("centred_green_block_on_red_block", "resting_green_block_on_red_block", "released_green_block")
    src, els = program_for(coder, sg, make_elements, _place_state([0.4, 0.1, 0.14], [0.4, 0.1, 0.16]))
    v = run_program(src, els)
    assert v["attached_green_block"][0] is True and v["still_red_block"][0] is True  # carried
    assert not any(v[k][0] for k in upon)  # not placed yet
    # hovering centred above the target, still held: not complete
    v = run_program(src, make_elements(sg, _place_state([0.5, 0.0, 0.14], [0.5, 0.0, 0.16])))
    assert v["centred_green_block_on_red_block"][0] is True and v["resting_green_block_on_red_block"][0] is False
    assert v["released_green_block"][0] is False and classify(v["released_green_block"][1]) == "still_held"
    # dropped on the table on the way
    v = run_program(src, make_elements(sg, _place_state([0.4, 0.1, 0.02], [0.4, 0.1, 0.16])))
    ok, reason, margin = v["attached_green_block"]
    assert ok is False and margin < 0 and classify(reason) == "dropped"
    # placed and released (the tip came within 2.5 cm of it while carrying it), centred: every upon constraint holds
    placed = make_elements(sg, _place_state([0.505, 0.0, 0.06], [0.5, 0.0, 0.15]))
    v = run_program(src, placed, history_of(carried, placed))
    assert v["attached_green_block"][0] is True
    assert all(v[k][0] is True and v[k][2] > 0 for k in upon)
    # the same frame without the carried one in the history: the tip never came closer, so it may still hold it
    # (a block the cup took at the edge of its side face hangs that far from the tip)
    v = run_program(src, placed)
    assert v["released_green_block"][0] is False and classify(v["released_green_block"][1]) == "still_held"
    # placed 2.5 cm off centre: proactive failure, recovered by re-picking
    off = make_elements(sg, _place_state([0.525, 0.0, 0.06], [0.52, 0.0, 0.15]))
    v = run_program(src, off, history_of(carried, off))
    ok, reason, margin = v["centred_green_block_on_red_block"]
    assert ok is False and margin < 0 and classify(reason) == "offset"
    assert v["resting_green_block_on_red_block"][0] is True and v["released_green_block"][0] is True
    # the block below was pushed 3 cm during the placement
    els = make_elements(sg, _place_state([0.4, 0.1, 0.14], [0.4, 0.1, 0.16]))
    hist = [np.stack([e.points, e.points]) for e in els]
    red_id = next(e.id for e in els if e.owner == ("red_block", ""))
    hist[red_id] = np.stack([els[red_id].points - [0.03, 0, 0], els[red_id].points])
    v = run_program(src, els, hist)
    assert v["still_red_block"][0] is False and classify(v["still_red_block"][1]) == "collapse"


def test_place_blue_tower_check(make_elements, run_program):
    gen, coder = gen_coder()
    sg = _subgoal(gen, infer_objects(STACK), 3)
    pts = {("robot", "tip"): [0.4, 0.1, 0.2], ("blue_block", ""): [0.4, 0.1, 0.18],
           ("green_block", ""): [0.5, 0.0, 0.06], ("red_block", ""): [0.5, 0.0, 0.02]}
    src, els = program_for(coder, sg, make_elements, pts)
    assert run_program(src, els)["tower_green_block_on_red_block"][0] is True
    pts[("green_block", "")] = [0.56, 0.0, 0.02]  # fell off
    ok, reason, _ = run_program(src, make_elements(sg, pts))["tower_green_block_on_red_block"]
    assert ok is False and classify(reason) == "collapse"


def _zone_and_blocks(n_in: int, n_total: int = 40):
    pts = {("zone", "surface"): [[0.3, -0.1, 0.0], [0.5, -0.1, 0.0], [0.5, 0.1, 0.0], [0.3, 0.1, 0.0]]}
    for i in range(n_total):
        x = 0.31 + 0.18 * (i % 7) / 6 if i < n_in else 0.7 + 0.01 * (i % 7)
        pts[(f"block_{i:02d}", "")] = [x, -0.09 + 0.18 * (i // 7) / 6, 0.02]
    return pts


def test_sweep_plan_and_program(make_elements, run_program):
    gen, coder = gen_coder()
    objs = infer_objects(SWEEP)
    sg = gen.next_subgoal(SWEEP, IMG, objs)
    assert sg.action.to_dict() == {"skill": "push_into_region", "args": {"region": "zone"}}
    upon = sg.upon()[0]
    assert 16 <= upon.thresholds["target"] <= 24
    assert (upon.thresholds["lower"], upon.thresholds["upper"]) == (16, 24)
    assert "halts at" in gen.last_output.reasoning
    zone = next(p for p in upon.parts if p.obj == "zone")
    assert (zone.part, zone.kind.value) == ("surface", "surface")
    src, els = program_for(coder, sg, make_elements, _zone_and_blocks(5))
    v = run_program(src, els)
    assert v[upon.id][0] is False and v[sg.during()[0].id][0] is True
    v = run_program(src, make_elements(sg, _zone_and_blocks(int(upon.thresholds["target"]))))
    assert v[upon.id][0] is True
    v = run_program(src, make_elements(sg, _zone_and_blocks(30)))
    assert v[upon.id][0] is True and v[sg.during()[0].id][0] is False
    assert classify(v[sg.during()[0].id][1]) == "overshoot"
    assert gen.next_subgoal(SWEEP, IMG, objs, sg, "success").done


def rope_state(closed: bool, n: int = 20) -> dict:
    """Opening along y at x = 0.5 between corner_3 (y=-0.1) and corner_0 (y=+0.1); beads along it or away."""
    pts = {("square", "corner_0"): [0.5, 0.1, 0.0], ("square", "corner_3"): [0.5, -0.1, 0.0]}
    for i in range(n):
        y = (i - (n - 1) / 2) * 0.017 * 0.85
        pts[("rope", f"bead_{i:02d}")] = [0.515, y, 0.008] if closed else [0.65 + 0.01 * (i % 3), y, 0.008]
    return pts


def test_rope_plan_and_program(make_elements, run_program):
    gen, coder = gen_coder()
    objs = infer_objects(ROPE)
    sg = gen.next_subgoal(ROPE, IMG, objs)
    assert sg.action.to_dict() == {"skill": "close_shape", "args": {"rope": "rope", "shape": "square"}}
    parts = [(p.obj, p.part) for p in sg.constraints[0].parts]
    assert parts[:3] == [("square", "corner_0"), ("square", "corner_3"), ("rope", "bead_00")]
    assert parts[-1] == ("rope", "bead_19") and len(parts) == 22
    src, els = program_for(coder, sg, make_elements, rope_state(True))
    assert run_program(src, els)["rope_covers_opening"][0] is True
    assert run_program(src, make_elements(sg, rope_state(False)))["rope_covers_opening"][0] is False
    lifted = rope_state(True)
    for i in range(7, 13):  # six middle beads lifted (being carried) leave a gap of about 9 cm
        lifted[("rope", f"bead_{i:02d}")][2] = 0.05
    assert run_program(src, make_elements(sg, lifted))["rope_covers_opening"][0] is False
    # beads 2.2 cm from the opening meet the task's 2.5 cm, but not with the margin for element error
    borderline = rope_state(True)
    for k, v in borderline.items():
        if k[0] == "rope":
            v[0] = 0.522
    assert run_program(src, make_elements(sg, borderline))["rope_covers_opening"][0] is False
    assert gen.next_subgoal(ROPE, IMG, objs, sg, "success").done
    # the scene may list the rope's parts; the kb then uses them
    sg = gen.next_subgoal(ROPE, IMG, [*objs, "rope/bead_00", "rope/bead_01", "rope/bead_02"])
    assert len(sg.constraints[0].parts) == 5


def test_every_subgoal_program_passes_the_static_check():
    gen, coder = gen_coder()
    for instr in (STACK, SWEEP, ROPE):
        objs, prev = infer_objects(instr), None
        for _ in range(6):
            sg = gen.next_subgoal(instr, IMG, objs, prev, "success" if prev else None)
            if sg.done:
                break
            specs = legend_specs(sg)
            els = [Element(i, s.name, s.kind, np.eye(3)[: s.kind.min_points] + i, (s.obj, s.part))
                   for i, s in enumerate(specs)]
            coder.write_program(sg, els, IMG, basic_check([c.id for c in sg.constraints]))
            prev = sg
        assert sg.done, instr


def test_kb_is_deterministic_and_honest_about_itself():
    be = KBBackend()
    gen = ConstraintGenerator(be)
    msgs = gen.build_messages(STACK, IMG, infer_objects(STACK), None, None)
    a, b = be.complete(msgs, purpose="constraint_generator"), be.complete(msgs, purpose="constraint_generator")
    assert a == b and a.model == "kb-rules-v1" and a.estimated
    assert a.text.startswith("```json")


def test_kb_unknown_instruction_is_a_clear_error():
    gen, _ = gen_coder()
    with pytest.raises(VLMError, match="did not understand 'fold', 'towel'") as info:
        gen.next_subgoal("fold the towel in half", IMG, ["towel", "table"])
    for task in ("stack-in-order", "sweep-half", "rope-close-square", "slot-pen", "stow-book", "pour-tea",
                 "open-drawer"):
        assert task in str(info.value)


def test_compact_answer_leaves_out_only_what_the_schema_fills_in():
    import json

    from code_as_monitor.vlm.kb import compact_answer
    from code_as_monitor.vlm.kb.planner import next_subgoal
    from code_as_monitor.vlm.schemas import parse_generator_output

    objects = infer_objects(STACK)
    previous = {"text": "pick up the green block", "done": False,
                "action": {"skill": "pick", "args": {"obj": "green_block"}}}
    full = next_subgoal({"instruction": STACK, "objects": objects, "previous_subgoal": previous,
                         "feedback": "success"})
    short = compact_answer(full)
    assert len(json.dumps(short)) < len(json.dumps(full))
    assert '"part": ""' not in json.dumps(short) and '"proactive": false' not in json.dumps(short)
    assert any(c.get("proactive") for c in short["constraints"])  # a true flag stays
    ctx = {"objects": [*objects, "robot"], "skills": ["pick", "place_on"]}
    assert parse_generator_output(short, ctx).to_subgoal() == parse_generator_output(full, ctx).to_subgoal()
