"""Clear-the-top (issue 16): a collapse can leave one block lying on another. Every stacking pick checks that
nothing rests on the block to pick or on the block it goes on; when something does, the kb takes the blocker off,
sets it aside on the table and rebuilds from the level it was at."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.shared.feedback import classify

STACK = "stack the blocks: red at the bottom, then green, then blue"
IMG = {"front": np.zeros((8, 8, 3), np.uint8)}
TABLE = {("robot", "tip"): [0.3, -0.3, 0.3], ("red_block", ""): [0.5, 0.0, 0.02],
         ("green_block", ""): [0.4, 0.15, 0.02], ("blue_block", ""): [0.6, -0.15, 0.02]}


def _first_pick():
    gen = ConstraintGenerator(KBBackend())
    return gen, gen.next_subgoal(STACK, IMG, infer_objects(STACK))


def _program(subgoal, make_elements, points):
    els = make_elements(subgoal, points)
    src = MonitorCoder(KBBackend()).write_program(subgoal, els, IMG, basic_check([c.id for c in subgoal.constraints]))
    return src


@pytest.mark.parametrize("blocker_z", [0.06, 0.065])
def test_a_block_lying_on_the_target_blocks_the_pick(make_elements, run_program, blocker_z):
    _, sg = _first_pick()
    src = _program(sg, make_elements, TABLE)
    assert run_program(src, make_elements(sg, TABLE))["clear_red_block"][0] is True
    onto = dict(TABLE)
    onto[("blue_block", "")] = [0.51, 0.005, blocker_z]  # blue lies on red, slightly askew
    ok, reason, margin = run_program(src, make_elements(sg, onto))["clear_red_block"]
    assert ok is False and margin < 0 and classify(reason) == "blocked"
    assert "blue_block" in reason and "red_block" in reason
    beside = dict(TABLE)
    beside[("blue_block", "")] = [0.56, 0.0, 0.02]  # touching red on the table, not on it
    assert run_program(src, make_elements(sg, beside))["clear_red_block"][0] is True


def test_blocked_feedback_clears_the_blocker_then_rebuilds():
    gen, sg = _first_pick()
    objs = infer_objects(STACK)
    fb = ("failure: clear_red_block: blue_block rests on top of red_block (offset 0.005 m): it blocks the tower, "
          "clear it first")
    take = gen.next_subgoal(STACK, IMG, objs, sg, fb)
    assert take.action.to_dict() == {"skill": "pick", "args": {"obj": "blue_block"}}
    assert any(c.id == "held_blue_block" for c in take.constraints)
    aside = gen.next_subgoal(STACK, IMG, objs, take, "success")
    assert aside.action.to_dict() == {"skill": "place_on", "args": {"obj": "blue_block", "target": "table"}}
    again = gen.next_subgoal(STACK, IMG, objs, aside, "success")
    assert again.action.to_dict() == {"skill": "pick", "args": {"obj": "green_block"}}
    # a clearing pick that did not take the blocker is tried again, still as a clearing pick
    retry = gen.next_subgoal(STACK, IMG, objs, take, "failure: held_blue_block: blue_block is not held")
    assert retry.action.to_dict() == take.action.to_dict() and "to clear" in retry.text
