"""Path coverage moves the point elements of one object part together in its meeting and placement probes (the
ablation "CP off" hands a line over as two points); with one element per part the probes are as before."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core import Constraint, ElementSpec, Phase
from code_as_monitor.monitor.coverage import part_groups
from code_as_monitor.monitor.perturb import make_probes

ELEMENTS = {0: np.array([[0.40, 0.10, 0.01]]), 1: np.array([[0.50, 0.10, 0.01]]), 2: np.array([[0.3, -0.3, 0.3]])}


def test_part_groups_follow_the_constraints_parts() -> None:
    pen0 = ElementSpec("pen body p1/2", "pen", "body", "point")
    pen1 = ElementSpec("pen body p2/2", "pen", "body", "point")
    tip = ElementSpec("grasp point", "robot", "tip", "point")
    cons = [Constraint("held", "x", Phase.UPON, [tip, pen0, pen1], element_ids=[2, 0, 1])]
    assert part_groups(cons) == {2: [2], 0: [0, 1], 1: [0, 1]}
    assert part_groups([Constraint("x", "x", Phase.UPON, [tip], element_ids=[])]) == {}


def test_meetings_and_placements_move_a_parts_points_together() -> None:
    groups = {0: [0, 1], 1: [0, 1], 2: [2]}
    probes = make_probes(ELEMENTS, None, None, 1.0, 8, groups=groups)
    meet = next(p for p in probes
                if p.description.startswith("element 2 raised") and "element 0 moved" in p.description)
    d0, d1 = meet.elements[0] - ELEMENTS[0], meet.elements[1] - ELEMENTS[1]
    assert np.allclose(d0, d1) and np.linalg.norm(d0) > 0.1, "the pen's two points moved as one"
    mid = (meet.elements[0] + meet.elements[1]).mean(axis=0) / 2
    assert np.allclose(mid[:2], meet.elements[2][0, :2]), "their centre went to the raised tip"
    place = next(p for p in probes
                 if p.description.startswith("element 1 placed") and "above element 2" in p.description)
    assert np.allclose(place.elements[0] - ELEMENTS[0], place.elements[1] - ELEMENTS[1])
    within = next(p for p in probes
                  if p.description.startswith("element 0 placed") and "above element 1" in p.description)
    assert np.allclose(within.elements[1], ELEMENTS[1]), "two points of one part: only the one named moves"


def test_one_element_per_part_gives_the_same_probes_as_no_groups() -> None:
    a = make_probes(ELEMENTS, None, None, 1.0, 20)
    b = make_probes(ELEMENTS, None, None, 1.0, 20, groups={0: [0], 1: [1], 2: [2]})
    assert [p.description for p in a] == [p.description for p in b]
    for p, q in zip(a, b):
        assert all(np.array_equal(p.elements[i], q.elements[i]) for i in p.elements)


def test_a_parts_points_turn_together_into_their_current_pose() -> None:
    probes = make_probes(ELEMENTS, None, None, 1.0, 4, groups={0: [0, 1], 1: [0, 1], 2: [2]})
    turns = [p for p in probes if "elements 0, 1 (one part) turned" in p.description]
    assert len(turns) >= 2
    for p in turns:
        gap = np.linalg.norm(p.history[0][:, 0] - p.history[1][:, 0], axis=1)
        assert np.allclose(gap, 0.1), "a rigid turn keeps the points' distance"
        assert np.allclose(p.history[0][-1], ELEMENTS[0]) and not np.allclose(p.history[0][0], ELEMENTS[0])
