"""The v2 prompts say each thing once and still carry what the answers' validation needs."""

from __future__ import annotations

import re

import numpy as np

from code_as_monitor.core.constraints import Action, Constraint, Subgoal
from code_as_monitor.core.elements import Element, ElementSpec
from code_as_monitor.planning.coder import MonitorCoder, legend_specs
from code_as_monitor.planning.generator import ConstraintGenerator
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.parsing import extract_request
from code_as_monitor.vlm.schemas import ActionOut, ConstraintOut, GeneratorOutput, PartOut
from code_as_monitor.vlm.skills import DEFAULT_SKILLS
from code_as_monitor.vlm.usage import estimate_prompt_tokens

VIEWS = {"front": np.zeros((240, 320, 3), np.uint8), "top": np.zeros((240, 320, 3), np.uint8)}


class Capture:
    def __init__(self) -> None:
        self.messages: list[Message] = []

    def complete(self, messages, *, purpose, schema=None):
        raise AssertionError("not called")


def _subgoal() -> Subgoal:
    tip = ElementSpec("tip", "robot", "tip", "point")
    g = ElementSpec("green", "green_block", "", "point")
    r = ElementSpec("red", "red_block", "", "point")
    return Subgoal("place green on red", [
        Constraint("attached", "green stays attached", "during", [tip, g], thresholds={"max_dist": 0.05}),
        Constraint("centred", "green centred on red", "upon", [g, r], proactive=True, thresholds={"max_offset": 0.01}),
    ], Action("place_on", {"obj": "green_block", "target": "red_block"}))


def _planner_messages() -> list[Message]:
    gen = ConstraintGenerator(Capture(), skills={k: DEFAULT_SKILLS[k] for k in ("pick", "place_on")})
    return gen.build_messages("stack green on red", VIEWS, ["green_block", "red_block"], _subgoal(),
                              "failure: attached: green_block fell")


def _coder_messages() -> list[Message]:
    sg = _subgoal()
    els = [Element(i, s.name, s.kind, np.zeros((1, 3)), (s.obj, s.part)) for i, s in enumerate(legend_specs(sg))]
    return MonitorCoder(Capture()).build_messages(sg, els, VIEWS)


def _sentences(text: str) -> set[str]:
    return {s.strip() for s in re.split(r"(?<=[.:;])\s+|\n", text) if len(s.strip()) >= 30}


def test_no_sentence_is_repeated_across_the_plan_and_code_calls():
    plan, code = _planner_messages(), _coder_messages()
    assert not _sentences(plan[0].text) & _sentences(code[0].text)
    for msgs in (plan, code):  # nor within a call: the system prompt, the request and the view labels
        system, user = _sentences(msgs[0].text), _sentences(msgs[1].text)
        assert not system & user


def test_each_request_value_is_sent_once():
    user = _planner_messages()[1].text
    assert user.count("stack green on red") == 1 and user.count("green_block fell") == 1
    assert user.count("place green on red") == 1  # the previous subgoal, without its constraints again
    code = _coder_messages()[1].text
    for phrase in ("green stays attached", "green centred on red", "robot/tip", "max_offset"):
        assert code.count(phrase) == 1, phrase
    req = extract_request(code)
    assert all("parts" not in c for c in req["constraints"])  # parts only through the legend


def test_the_planner_prompt_names_every_field_validation_checks():
    system = _planner_messages()[0].text
    for model in (GeneratorOutput, ConstraintOut, ActionOut, PartOut):
        for field in model.model_fields:
            assert f'"{field}"' in system, (model.__name__, field)
    for v in ("during", "upon", "point", "line", "surface", "`pick`", "`place_on`"):
        assert v in system, v
    assert "`pour`" not in system  # only the policy's skills


def test_one_low_detail_image_per_call_for_two_small_views():
    for msgs in (_planner_messages(), _coder_messages()):
        [im] = msgs[1].images
        assert im.detail == "low"
    # the estimate counts that image once, at 85, whatever the default detail
    msgs = _coder_messages()
    text_only = estimate_prompt_tokens(msgs, images=False)
    assert estimate_prompt_tokens(msgs, detail="high") == text_only + 85
