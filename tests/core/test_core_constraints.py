"""Constraint / Action / Subgoal / Verdict: validation and to_dict / from_dict round trips."""

from __future__ import annotations

import json
import math

import pytest

from code_as_monitor.core.constraints import Action, Constraint, Phase, Subgoal, Verdict
from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ConfigError


def _subgoal() -> Subgoal:
    c1 = Constraint(
        "tip_above_block", "the suction cup is above the red block", "during",
        parts=[ElementSpec("tip", "robot", "tip"), ElementSpec("red top", "red_block", "top", ElementKind.SURFACE)],
        element_ids=[1, 2], thresholds={"max_offset": 0.02}, proactive=True,
    )
    c2 = Constraint("block_lifted", "the red block is lifted", Phase.UPON, [ElementSpec("red", "red_block")])
    return Subgoal("pick up the red block", [c1, c2], Action("pick", {"obj": "red_block"}))


def test_subgoal_round_trip_through_json() -> None:
    sg = _subgoal()
    back = Subgoal.from_dict(json.loads(json.dumps(sg.to_dict())))
    assert back == sg
    assert [c.id for c in back.during()] == ["tip_above_block"]
    assert [c.id for c in back.upon()] == ["block_lifted"]
    assert back.constraints[0].function_name == "check_tip_above_block"
    assert back.constraints[0].parts[1].kind is ElementKind.SURFACE
    done = Subgoal("task complete", done=True)
    assert Subgoal.from_dict(done.to_dict()) == done and done.action is None


def test_constraint_validation_names_bad_values() -> None:
    with pytest.raises(ConfigError, match=r"'2fast'.*not a valid identifier"):
        Constraint("2fast", "x", "during")
    with pytest.raises(ConfigError, match="unknown phase 'before'"):
        Constraint("ok", "x", "before")
    assert Phase.parse(" UPON ") is Phase.UPON
    c = Constraint.from_dict({"id": "a", "text": "t", "phase": "during"})
    assert c.parts == [] and c.thresholds == {} and c.proactive is False and c.monotone == []
    with pytest.raises(ConfigError, match=r"monotone entries \['rope'\] name none of its parts"):
        Constraint("a", "t", "upon", [ElementSpec("red", "red_block")], monotone=["rope"])


def test_monotone_members_by_object_or_part_name() -> None:
    parts = [ElementSpec("corner", "square", "corner_0")]
    parts += [ElementSpec(f"bead {i}", "rope", f"b{i}") for i in range(3)]
    c = Constraint("covered", "t", "upon", parts, element_ids=[7, 3, 4, 5], monotone=["rope"])
    assert c.monotone_element_ids() == {3, 4, 5}
    assert Constraint.from_dict(c.to_dict()) == c and c.to_dict()["monotone"] == ["rope"]
    assert Constraint("c", "t", "upon", parts, element_ids=[7, 3, 4, 5], monotone=["bead 1"]).monotone_element_ids() \
        == {4}
    assert "monotone" not in Constraint("c", "t", "upon", parts).to_dict()
    assert Constraint("c", "t", "upon", parts, monotone=["rope"]).monotone_element_ids() == set()  # ids not filled


def test_verdict_to_dict_maps_nan_margin_to_null() -> None:
    v = Verdict("a", Phase.DURING, False, "tilted", t=1.5)
    d = v.to_dict()
    assert d["margin"] is None and d["phase"] == "during" and d["fault"] is False
    assert Verdict("a", Phase.UPON, True, "ok", margin=0.01).to_dict()["margin"] == 0.01
    assert math.isnan(v.margin)
    json.dumps(d)


def test_action_round_trip() -> None:
    a = Action("place_on", {"obj": "green_block", "target": "red_block", "xy": [0.1, 0.2]})
    assert Action.from_dict(a.to_dict()) == a
    assert Action.from_dict({"skill": "pick"}).args == {}
