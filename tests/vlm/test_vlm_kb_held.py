"""Every kb "held / lifted / picked up" check is relative to the grasp: an object resting high (on another block,
in the shelf) under a hovering tip is not held; one that rose with the tip since the grasp began is.

Parametrised over every registered kb family: each family's plan is walked with success feedback, and every
upon constraint whose template is the shared held check is tried on constructed states."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core import Element
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check, legend_specs
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.registry import all_templates, families
from code_as_monitor.vlm.kb.shared.grip import held_since_grasp

X5 = np.array([0.05, 0.0, 0.0])
ABOVE = np.array([0.0, 0.0, 0.012])  # the tip just above the object's centre (within every max_dist)
HELD_KEYS = sorted(k for k, fn in all_templates().items() if fn is held_since_grasp)


def _held_subgoals() -> list[tuple[str, object, str]]:
    """(family, subgoal, constraint id) for every held-template constraint met on each family's plan."""
    out = []
    for fam in families():
        gen, prev = ConstraintGenerator(KBBackend()), None
        for _ in range(12):
            prev = gen.next_subgoal(fam.example, {}, infer_objects(fam.example), prev, "success" if prev else None)
            if prev.done:
                break
            out += [(fam.name, prev, c.id) for c in prev.constraints if c.id.split("_", 1)[0] in HELD_KEYS]
    return out


CASES = _held_subgoals()


def _shape(kind: str, c: np.ndarray) -> np.ndarray:
    """Points of an element of ``kind`` centred at ``c`` (3,)."""
    if kind == "point":
        return c[None]
    if kind == "line":
        return np.stack([c - X5, c + X5])
    return c + np.array([[-0.03, -0.03, 0], [0.03, -0.03, 0], [0.03, 0.03, 0], [-0.03, 0.03, 0]])


def _elements(subgoal, where: dict[str, np.ndarray], default: np.ndarray) -> list[Element]:
    """Legend elements: ``where[obj]`` for the named objects (``robot`` is the tip), ``default`` elsewhere."""
    out = []
    for i, s in enumerate(legend_specs(subgoal)):
        c = np.asarray(where.get(s.obj, default), dtype=float)
        out.append(Element(i, s.name, s.kind, _shape(s.kind.value, c), (s.obj, s.part)))
    return out


def test_every_family_that_grasps_has_a_held_check():
    names = {fam for fam, _, _ in CASES}
    assert {"stack", "pen", "book", "tea"} <= names, names


@pytest.mark.parametrize(("family", "subgoal", "cid"), CASES, ids=[f"{f}-{c}" for f, _, c in CASES])
def test_resting_high_under_a_hovering_tip_is_not_held_and_rising_with_it_is(family, subgoal, cid, run_program):
    coder = MonitorCoder(KBBackend())
    c = next(c for c in subgoal.constraints if c.id == cid)
    obj = next(p.obj for p in c.parts if p.obj != "robot")
    far = np.array([0.3, -0.3, 0.3])
    resting = np.array([0.5, 0.05, 0.10])  # on another block, in a shelf: high before anything is grasped
    start = _elements(subgoal, {"robot": far, obj: resting}, np.array([0.45, -0.1, 0.02]))
    source = coder.write_program(subgoal, start, {}, basic_check([k.id for k in subgoal.constraints]))
    hover = _elements(subgoal, {"robot": resting + ABOVE, obj: resting}, np.array([0.45, -0.1, 0.02]))
    history = [np.stack([a.points, b.points]) for a, b in zip(start, hover)]
    ok, reason, margin = run_program(source, hover, history)[cid]
    assert ok is False and margin < 0, reason
    up = resting + 10 * ABOVE
    lifted = _elements(subgoal, {"robot": up + ABOVE, obj: up}, np.array([0.45, -0.1, 0.02]))
    history = [np.stack([a.points, b.points]) for a, b in zip(start, lifted)]
    ok, reason, margin = run_program(source, lifted, history)[cid]
    assert ok is True and margin > 0, reason
