"""The kb's stack and grasp checks give short reasons (prompts v5 ask for a short phrase), and every failure reason
still reads, for the kb planner's feedback classifier, as the failure the check is about: the recovery a re-plan
chooses depends on it (``vlm.kb.shared.feedback``)."""

from __future__ import annotations

import ast

import numpy as np

from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.backend import KBBackendConfig, make_backend
from code_as_monitor.vlm.kb.coder import write_program
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.shared.feedback import classify, mentioned

STACK = "stack the blocks: red at the bottom, then green, then blue"
IMG = {"front": np.zeros((8, 8, 3), np.uint8)}
BLOCKS = ["red_block", "green_block", "blue_block"]
CATEGORY = {"attached": "dropped", "still": "collapse", "centred": "offset", "resting": "dropped",
            "released": "still_held", "tower": "collapse", "plumb": "collapse", "held": "dropped", "taken": "taken"}
"""Template key (constraint id prefix) -> the feedback category its failure must read as."""


def _subgoals() -> list:
    """The undisturbed plan's subgoals and the re-plans after a dropped block and after a knocked level."""
    be = make_backend(KBBackendConfig())
    gen = ConstraintGenerator(be)
    objs = infer_objects(STACK)
    out, prev = [], None
    for _ in range(4):
        prev = gen.next_subgoal(STACK, IMG, objs, prev, None if prev is None else "success")
        out.append(prev)
    drop = "failure: attached_blue_block: blue_block dropped: 0.200 m from the tip, not on green_block"
    out.append(gen.next_subgoal(STACK, IMG, objs, out[3], drop))
    return out


def _failure_literals(source: str) -> dict[str, list[str]]:
    """Check name -> the format strings of its ``return False, '...' % ...`` statements."""
    out: dict[str, list[str]] = {}
    for fn in ast.parse(source).body:
        if not isinstance(fn, ast.FunctionDef):
            continue
        for node in ast.walk(fn):
            if (isinstance(node, ast.Return) and isinstance(node.value, ast.Tuple)
                    and isinstance(node.value.elts[0], ast.Constant) and node.value.elts[0].value is False):
                msg = node.value.elts[1]
                fmt = msg.left if isinstance(msg, ast.BinOp) else msg
                assert isinstance(fmt, ast.Constant) and isinstance(fmt.value, str)
                out.setdefault(fn.name, []).append(fmt.value)
    return out


def _request(sg) -> dict:
    """The coder request of subgoal ``sg`` as the coder sends it: constraints with element ids into a legend."""
    legend: dict[tuple[str, str, str], int] = {}
    cons = []
    for c in sg.constraints:
        ids = [legend.setdefault((p.obj, p.part, p.kind.value), len(legend)) for p in c.parts]
        cons.append({"id": c.id, "text": c.text, "phase": c.phase.value, "thresholds": dict(c.thresholds),
                     "element_ids": ids})
    rows = [[i, kind, f"{obj}/{part}" if part else obj] for (obj, part, kind), i in legend.items()]
    return {"subgoal": sg.text, "constraints": cons, "elements": rows}


def test_every_failure_reason_reads_as_its_checks_failure() -> None:
    seen = set()
    for sg in _subgoals():
        literals = _failure_literals(write_program(_request(sg)))
        for c in sg.constraints:
            key = c.id.split("_")[0]
            assert key in CATEGORY, c.id
            objs = {p.obj for p in c.parts}
            for fmt in literals[f"check_{c.id}"]:
                reason = fmt.replace("%.3f", "0.123").replace("%.1f", "1.2")
                assert classify(f"failure: {c.id}: {reason}") == CATEGORY[key], (c.id, reason)
                assert set(mentioned(reason, BLOCKS)) <= objs, (c.id, reason)
                assert len(reason) <= 110, (c.id, reason)  # a short phrase (the v4-era plumb reason had 134 characters)
            seen.add(key)
    assert seen == set(CATEGORY), set(CATEGORY) - seen
