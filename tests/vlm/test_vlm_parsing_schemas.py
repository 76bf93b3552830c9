"""Parsing helpers, the generator schema, usage accounting and the prompt templates."""

from __future__ import annotations

import re

import numpy as np
import pytest

from code_as_monitor.core.errors import ConfigError, VLMOutputError
from code_as_monitor.geometry.helpers import MONITOR_HELPERS
from code_as_monitor.vlm.backend import VLMBackendConfig, VLMResponse
from code_as_monitor.vlm.messages import ImagePart, Message
from code_as_monitor.vlm.parsing import dump_request, extract_json, extract_request, strip_code_fences
from code_as_monitor.vlm.schemas import parse_generator_output
from code_as_monitor.vlm.templates import load_template, placeholders, render
from code_as_monitor.vlm.usage import UsageMeter


def test_strip_code_fences():
    assert strip_code_fences("```python\ndef f():\n    pass\n```\nthanks") == "def f():\n    pass\n"
    assert strip_code_fences("Here:\n```\nx = 1\n```") == "x = 1\n"
    assert strip_code_fences("x = 1") == "x = 1\n"
    two = "```json\n{}\n```\n```python\ny = 2\n```"
    assert strip_code_fences(two) == "y = 2\n"
    assert strip_code_fences("```python\nz = 3\n") == "z = 3\n"  # unterminated fence


def test_extract_json():
    assert extract_json('Sure! ```json\n{"a": 1}\n```') == {"a": 1}
    assert extract_json('prefix {"a": {"b": 2}} suffix') == {"a": {"b": 2}}
    with pytest.raises(VLMOutputError, match="no JSON object"):
        extract_json("nothing here")
    with pytest.raises(VLMOutputError, match="invalid JSON"):
        extract_json('{"a": 1,,}')


def test_request_block_round_trip():
    req = {"instruction": "x", "objects": ["a", "b"], "feedback": None}
    assert extract_request("text\n" + dump_request(req) + "\nmore") == req
    assert extract_request("```json\n{}\n```") is None


GOOD = {
    "subgoal": "pick up the green block",
    "action": {"skill": "pick", "args": {"obj": "green_block"}},
    "constraints": [{"id": "held", "text": "held", "phase": "upon",
                     "parts": [{"name": "tip", "obj": "robot", "part": "tip", "kind": "point"},
                               {"name": "g", "obj": "green_block", "kind": "point"}]}],
}
CTX = {"objects": ["green_block", "robot", "table"], "skills": ["pick"]}


def test_schema_accepts_and_converts():
    sg = parse_generator_output(GOOD, CTX).to_subgoal()
    assert sg.action.skill == "pick" and sg.constraints[0].phase.value == "upon"
    assert sg.constraints[0].parts[1].part == "" and not sg.done
    assert sg.constraints[0].monotone == []
    obj = GOOD["constraints"][0]["parts"][1]["obj"]
    set_like = {**GOOD, "constraints": [{**GOOD["constraints"][0], "monotone": [obj]}]}
    assert parse_generator_output(set_like, CTX).to_subgoal().constraints[0].monotone == [obj]
    done = parse_generator_output({"subgoal": "task complete", "done": True}, CTX).to_subgoal()
    assert done.done and done.constraints == [] and done.action is None


@pytest.mark.parametrize(
    ("patch", "message"),
    [
        ({"action": None}, "'action' is required"),
        ({"constraints": []}, "at least one constraint"),
        ({"action": {"skill": "teleport"}}, "unknown skill 'teleport'"),
        ({"constraints": [{**GOOD["constraints"][0], "id": "not an id"}]}, "constraints.0.id"),
        ({"constraints": [GOOD["constraints"][0]] * 2}, "repeated: held"),
        ({"constraints": [{**GOOD["constraints"][0], "parts": [{"name": "x", "obj": "pan", "kind": "point"}]}]},
         "object 'pan' is not in the scene"),
        ({"constraints": [{**GOOD["constraints"][0], "parts": [{"name": "x", "obj": "robot", "kind": "blob"}]}]},
         "kind"),
        ({"done": True}, "must have no constraints"),
        ({"extra": 1}, "extra"),
        ({"constraints": [{**GOOD["constraints"][0], "monotone": ["rope"]}]}, r"monotone entries \['rope'\]"),
    ],
)
def test_schema_rejects_with_readable_errors(patch, message):
    with pytest.raises(VLMOutputError, match=message):
        parse_generator_output({**GOOD, **patch}, CTX)


def test_usage_meter_per_subgoal_and_episode():
    m = UsageMeter()
    m.record("constraint_generator", VLMResponse("x", 5, 1, "m"))  # before any subgoal: counted as 0
    m.start_subgoal()
    m.record("monitor_coder", VLMResponse("x", 10, 2, "m"))
    m.start_subgoal()
    m.record("constraint_generator", VLMResponse("x", 100, 20, "m", estimated=True))
    m.record("vqa", VLMResponse("x", 1, 1, "m"))
    per = m.per_subgoal()
    assert [p["calls"] for p in per] == [2, 2]
    assert per[1]["calls_by_purpose"] == {"constraint_generator": 1, "vqa": 1}
    ep = m.episode()
    assert (ep["calls"], ep["prompt_tokens"], ep["completion_tokens"], ep["subgoals"]) == (4, 116, 24, 2)
    assert ep["estimated"] and ep["calls_per_subgoal"] == 2.0
    assert m.to_dict()["per_subgoal"][0]["total_tokens"] == 18


def test_prompt_templates():
    assert placeholders("constraint_generator") == {"skills"}
    # v4 on: one line saying the annotated views follow, filled only when the coder sends them (views=True)
    assert placeholders("monitor_coder") == {"image"}
    assert placeholders("monitor_coder", "v3") == set()
    coder = load_template("monitor_coder")
    for name in MONITOR_HELPERS:  # every helper a program may call is documented for the coder
        assert re.search(rf"\b{name}\(", coder), name
    with pytest.raises(ConfigError, match="missing values"):
        render("repair", error="x")
    with pytest.raises(ConfigError, match="not found"):
        load_template("monitor_coder", "v999")


def test_messages_and_registry():
    assert VLMBackendConfig.choices() == ["kb", "openai", "replay"]
    img = np.zeros((3, 4, 3), np.uint8)
    m = Message.user("hello", {"front": img})
    assert m.text == "hello\nView 'front':" and len(m.images) == 1
    assert m.to_record()["content"][2]["shape"] == [3, 4, 3]
    with pytest.raises(ConfigError, match="uint8"):
        ImagePart(np.zeros((3, 4), np.float32))
    with pytest.raises(ConfigError, match="role"):
        Message("robot", [])  # type: ignore[arg-type]
