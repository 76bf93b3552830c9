"""A collapse can leave one block lying on another; a suction cup sent down onto the lower one then takes the
upper one (or an earlier pick left a block on the cup, attached at the edge of a side face). A pick after a failure
watches the other blocks (a during check, ``taken``): one on the cup instead halts it with a reason naming it, and
the kb puts that one down first."""

from __future__ import annotations

import numpy as np

from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check
from code_as_monitor.vlm.backend import KBBackendConfig, make_backend
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.shared.feedback import classify

STACK = "stack the blocks: red at the bottom, then green, then blue"
IMG = {"front": np.zeros((8, 8, 3), np.uint8)}
NOT_HELD = "failure: held_green_block: green_block is not held: it rose 0.000 m since the grasp began"


def _gen():
    be = make_backend(KBBackendConfig())
    gen = ConstraintGenerator(be)
    return gen, MonitorCoder(be, usage=gen.usage)


def _repick(gen):
    objs = infer_objects(STACK)
    first = gen.next_subgoal(STACK, IMG, objs)
    return first, gen.next_subgoal(STACK, IMG, objs, first, NOT_HELD)


def test_only_a_pick_after_a_failure_watches_the_other_blocks():
    gen, _ = _gen()
    first, again = _repick(gen)
    assert [c.id for c in first.constraints] == ["held_green_block"]
    held, taken = again.constraints
    assert held.id == "held_green_block" and [p.obj for p in held.parts] == ["robot", "green_block"]
    assert taken.id == "taken_green_block" and taken.phase.value == "during" and not taken.proactive
    assert [p.obj for p in taken.parts] == ["robot", "green_block", "red_block", "blue_block"]


def _state(tip, green, red, blue=(0.7, -0.2, 0.02)):
    return {("robot", "tip"): list(tip), ("green_block", ""): list(green), ("red_block", ""): list(red),
            ("blue_block", ""): list(blue)}


def test_the_reason_names_the_block_the_cup_took(make_elements, run_program, history_of):
    gen, coder = _gen()
    _, again = _repick(gen)
    # red lies on green; the cup came down on green's spot, took red and rose with it
    start = make_elements(again, _state((0.5, 0.0, 0.25), (0.5, 0.0, 0.02), (0.505, 0.0, 0.06)))
    took_red = make_elements(again, _state((0.5, 0.0, 0.16), (0.5, 0.0, 0.02), (0.505, 0.0, 0.135)))
    src = coder.write_program(again, took_red, IMG, basic_check([c.id for c in again.constraints]))
    ok, reason, margin = run_program(src, took_red, history_of(start, took_red))["taken_green_block"]
    assert ok is False and margin < 0
    assert "red_block is on the tip instead of green_block" in reason and classify(reason) == "taken"
    # at the start nothing has moved: no verdict against the pick (a during check false at the start is rejected)
    assert run_program(src, start, history_of(start, start))["taken_green_block"][0] is True
    # nothing taken at all: this check holds, the held check says "not held" (red stays where it lay)
    missed = make_elements(again, _state((0.5, 0.0, 0.16), (0.5, 0.0, 0.02), (0.505, 0.0, 0.06)))
    v = run_program(src, missed, history_of(start, missed))
    assert v["taken_green_block"][0] is True and v["held_green_block"][0] is False
    assert classify(v["held_green_block"][1]) == "dropped"
    # red was already on the cup (taken at the edge of a side face by an earlier pick, 4.5 cm from the tip): it
    # moved with the tip all along, though it did not rise; blue, 6 cm from the tip but still, was not taken
    start = make_elements(again, _state((0.45, 0.0, 0.2), (0.6, 0.0, 0.02), (0.495, 0.0, 0.19), (0.5, 0.06, 0.1)))
    carried = make_elements(again, _state((0.48, 0.03, 0.1), (0.6, 0.0, 0.02), (0.525, 0.03, 0.09),
                                          (0.5, 0.06, 0.1)))
    ok, reason, _ = run_program(src, carried, history_of(start, carried))["taken_green_block"]
    assert ok is False and "red_block is on the tip instead" in reason
    still_red = make_elements(again, _state((0.48, 0.03, 0.1), (0.6, 0.0, 0.02), (0.495, 0.0, 0.19),
                                            (0.5, 0.06, 0.1)))
    assert run_program(src, still_red, history_of(start, still_red))["taken_green_block"][0] is True
    # green held (red, still lying where the cup took green from under it, is not read)
    held = make_elements(again, _state((0.5, 0.0, 0.16), (0.5, 0.0, 0.135), (0.5, 0.0, 0.1)))
    v = run_program(src, held, history_of(start, held))
    assert v["held_green_block"][0] is True and v["taken_green_block"][0] is True


def test_a_block_taken_instead_is_put_down_then_the_pick_is_tried_again():
    gen, _ = _gen()
    objs = infer_objects(STACK)
    _, again = _repick(gen)
    fb = ("failure: taken_green_block: red_block is on the tip instead of green_block (0.025 m from it, risen 0.075 "
          "m): green_block is not held")
    aside = gen.next_subgoal(STACK, IMG, objs, again, fb)
    assert aside.action.to_dict() == {"skill": "place_on", "args": {"obj": "red_block", "target": "table"}}
    assert [c.id for c in aside.constraints] == ["released_red_block"]
    nxt = gen.next_subgoal(STACK, IMG, objs, aside, "success")
    assert nxt.action.to_dict() == {"skill": "pick", "args": {"obj": "green_block"}}
