"""kb programs pass the monitor's own gates: static validation and white-box path coverage."""

from __future__ import annotations

import pytest

from code_as_monitor.planning import ConstraintGenerator, MonitorCoder
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects

validate = pytest.importorskip("code_as_monitor.monitor.validate")
coverage = pytest.importorskip("code_as_monitor.monitor.coverage")
sandbox = pytest.importorskip("code_as_monitor.monitor.sandbox")

STACK = "stack the blocks: red at the bottom, then green, then blue"
SWEEP = "sweep half of the blocks into the zone"
ROPE = "use the rope to close the opening of the square"

# Plausible states at the start of each stacking subgoal (world metres).
STACK_STARTS = [
    {("robot", "tip"): [0.4, 0.0, 0.3], ("green_block", ""): [0.5, 0.1, 0.02]},
    {("robot", "tip"): [0.5, 0.1, 0.16], ("green_block", ""): [0.5, 0.1, 0.14], ("red_block", ""): [0.4, -0.1, 0.02]},
    {("robot", "tip"): [0.4, 0.0, 0.3], ("blue_block", ""): [0.6, 0.1, 0.02], ("green_block", ""): [0.4, -0.1, 0.06],
     ("red_block", ""): [0.4, -0.1, 0.02]},
    {("robot", "tip"): [0.6, 0.1, 0.16], ("blue_block", ""): [0.6, 0.1, 0.14], ("green_block", ""): [0.4, -0.1, 0.06],
     ("red_block", ""): [0.4, -0.1, 0.02]},
]


def _sweep_start():
    pts = {("zone", "surface"): [[0.3, -0.1, 0.0], [0.5, -0.1, 0.0], [0.5, 0.1, 0.0], [0.3, 0.1, 0.0]]}
    for i in range(40):
        x = 0.35 if i < 4 else 0.6 + 0.01 * (i % 8)
        pts[(f"block_{i:02d}", "")] = [x, -0.2 + 0.01 * i, 0.02]
    return pts


ROPE_START = {("square", "corner_0"): [0.5, 0.1, 0.0], ("square", "corner_3"): [0.5, -0.1, 0.0]}
ROPE_START.update({("rope", f"bead_{i:02d}"): [0.65, -0.15 + 0.015 * i, 0.008] for i in range(20)})


def _cases():
    gen = ConstraintGenerator(KBBackend())
    prev = None
    for start in STACK_STARTS:
        prev = gen.next_subgoal(STACK, {}, infer_objects(STACK), prev, "success" if prev else None)
        yield prev, start
    yield gen.next_subgoal(SWEEP, {}, infer_objects(SWEEP)), _sweep_start()
    yield gen.next_subgoal(ROPE, {}, infer_objects(ROPE)), ROPE_START


def test_kb_programs_pass_validation_and_path_coverage(make_elements):
    coder = MonitorCoder(KBBackend())
    box = sandbox.Sandbox()
    box.start()
    try:
        for subgoal, start in _cases():
            els = make_elements(subgoal, start)
            cons = subgoal.constraints
            src = coder.write_program(subgoal, els, {}, lambda s, cons=cons: validate.validate_program(s, cons))
            E = {e.id: e.points for e in els}
            coverage.check_path_coverage(src, cons, E, None, None, 0.0, box,
                                     reject_failing_at_start=True)
        assert coder.usage.calls == 6  # one program per subgoal, no re-asks
    finally:
        box.close()
