"""CP off: ``split_into_points`` hands every line and surface over as point elements and rewrites the constraints."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core import Constraint, Element, ElementKind, ElementSpec, Phase, Subgoal
from code_as_monitor.painter.painter import assign_element_ids
from code_as_monitor.painter.point_elements import POINT_NAME, split_into_points

SQUARE = np.array([[0.0, 0.0, 0.1], [0.1, 0.0, 0.1], [0.1, 0.1, 0.1], [0.0, 0.1, 0.1]])


def _subgoal() -> Subgoal:
    tip = ElementSpec("grasp point", "robot", "tip", "point")
    spine = ElementSpec("book spine", "book", "spine", "line")
    slot = ElementSpec("shelf slot", "shelf", "slot", "surface")
    return Subgoal("stow", [Constraint("a", "a", Phase.DURING, [tip, spine]),
                            Constraint("b", "b", Phase.UPON, [spine, slot, tip])])


def test_lines_and_surfaces_become_their_points_in_order_and_constraints_use_them() -> None:
    sg = _subgoal()
    specs = assign_element_ids(sg)
    els = [Element.point(0, "grasp point", [0.3, 0.0, 0.3], ("robot", "tip")),
           Element.line(1, "book spine", np.array([0.5, 0.1, 0.0]), np.array([0.5, 0.1, 0.2]), ("book", "spine")),
           Element.surface(2, "shelf slot", SQUARE, ("shelf", "slot"))]
    points, new_specs, origin = split_into_points(els, specs, sg)
    assert [p.id for p in points] == list(range(7)) and all(p.kind is ElementKind.POINT for p in points)
    assert [p.name for p in points] == ["grasp point", "book spine p1/2", "book spine p2/2"] + [
        f"shelf slot p{i}/4" for i in range(1, 5)]
    assert np.allclose(np.vstack([p.points for p in points[3:]]), SQUARE)
    assert np.allclose(points[2].points, [[0.5, 0.1, 0.2]]) and points[2].owner == ("book", "spine")
    assert sg.constraints[0].element_ids == [0, 1, 2]
    assert sg.constraints[1].element_ids == [1, 2, 3, 4, 5, 6, 0]
    for c in sg.constraints:
        assert len(c.parts) == len(c.element_ids) and all(p.kind is ElementKind.POINT for p in c.parts)
    assert all(s.kind is ElementKind.POINT for s in new_specs.values()) and len(new_specs) == 7
    assert origin[4].parent_id == 2 and origin[4].index == 1 and 0 not in origin
    m = POINT_NAME.match(points[5].name)
    assert m and (m["base"], m["i"], m["n"]) == ("shelf slot", "3", "4")


def test_a_missing_element_keeps_one_point_id_and_is_left_missing() -> None:
    sg = _subgoal()
    specs = assign_element_ids(sg)
    els = [Element.point(0, "grasp point", [0.3, 0.0, 0.3], ("robot", "tip")),
           Element.surface(2, "shelf slot", SQUARE, ("shelf", "slot"))]
    points, new_specs, _ = split_into_points(els, specs, sg)
    assert len(new_specs) == 6 and [p.id for p in points] == [0, 2, 3, 4, 5]
    assert new_specs[1].name == "book spine" and new_specs[1].obj == "book"
    assert sg.constraints[0].element_ids == [0, 1]
