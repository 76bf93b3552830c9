"""The stack family's ``centred`` check judges a placed block's offset with a margin for the elements' reading
error: a block read 9 mm off the centre of the one below is not centred (before, anything up to the task's own
1 cm tolerance passed, and towers 1.0-1.2 cm off passed the monitor and failed the task)."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core import Element
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check, legend_specs
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.families.stack import THRESHOLDS
from code_as_monitor.vlm.kb.planner import infer_objects

INSTRUCTION = "stack the blocks: red at the bottom, then green, then blue"
RED = np.array([0.5, 0.05, 0.02])


def _place_subgoal():
    gen, prev = ConstraintGenerator(KBBackend()), None
    for _ in range(4):
        prev = gen.next_subgoal(INSTRUCTION, {}, infer_objects(INSTRUCTION), prev, "success" if prev else None)
        if prev.action and prev.action.skill == "place_on":
            return prev
    raise AssertionError("no place_on subgoal in the stack plan")


def _elements(subgoal, green: np.ndarray) -> list[Element]:
    where = {"red_block": RED, "green_block": green, "robot": green + np.array([0.0, 0.0, 0.15])}
    return [Element(i, s.name, s.kind, np.asarray(where.get(s.obj, [0.3, -0.2, 0.02]), float)[None], (s.obj, s.part))
            for i, s in enumerate(legend_specs(subgoal))]


def test_centred_is_judged_within_the_limit_less_the_reading_margin(run_program) -> None:
    subgoal = _place_subgoal()
    cid = next(c.id for c in subgoal.constraints if c.id.startswith("centred_"))
    start = _elements(subgoal, RED + np.array([0.0, 0.0, 0.04]))
    source = MonitorCoder(KBBackend()).write_program(subgoal, start, {},
                                                      basic_check([k.id for k in subgoal.constraints]))
    for dx, want in ((0.006, True), (0.009, False), (0.011, False)):
        now = _elements(subgoal, RED + np.array([dx, 0.0, 0.04]))
        ok, reason, margin = run_program(source, now)[cid]
        assert ok is want and (margin > 0) is want, (dx, reason)
    th = THRESHOLDS["centred"]
    assert 0 < th["margin"] < th["max_offset"]
