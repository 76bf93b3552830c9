"""ConstraintGenerator and MonitorCoder against a scripted in-process backend."""

from __future__ import annotations

import json

import numpy as np
import pytest

from code_as_monitor.core import Action, Constraint, Element, ElementKind, ElementSpec, Subgoal
from code_as_monitor.core.errors import ConfigError, ProgramError, VLMOutputError
from code_as_monitor.planning import (
    ConstraintGenerator,
    MonitorCoder,
    basic_check,
    legend_specs,
    program_defines_checks,
    resolve_element_ids,
)
from code_as_monitor.vlm.backend import VLMResponse
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.parsing import extract_request

OBJECTS = ["red_block", "green_block", "table"]
ANSWER = {
    "subgoal": "pick up the green block", "done": False,
    "action": {"skill": "pick", "args": {"obj": "green_block"}},
    "constraints": [{"id": "held", "text": "the green block is held", "phase": "upon", "thresholds": {"d": 0.04},
                     "parts": [{"name": "tip", "obj": "robot", "part": "tip", "kind": "point"},
                               {"name": "green", "obj": "green_block", "part": "", "kind": "point"}]}],
}


class Scripted:
    def __init__(self, *texts: str) -> None:
        self.texts = list(texts)
        self.calls: list[tuple[list[Message], str]] = []

    def complete(self, messages: list[Message], *, purpose: str, schema: dict | None = None) -> VLMResponse:
        self.calls.append((messages, purpose))
        return VLMResponse(self.texts.pop(0), 10, 5, "scripted")


def test_generator_request_carries_everything_eq1_needs():
    be = Scripted(json.dumps(ANSWER))
    gen = ConstraintGenerator(be)
    prev = Subgoal("pick up the red block", [], Action("pick", {"obj": "red_block"}))
    img = {"front": np.zeros((4, 4, 3), np.uint8), "top": np.ones((4, 4, 3), np.uint8)}
    sg = gen.next_subgoal("stack", img, OBJECTS, prev, "red_block dropped")
    assert sg.text == "pick up the green block" and sg.constraints[0].thresholds == {"d": 0.04}
    msgs, purpose = be.calls[0]
    assert purpose == "constraint_generator" and [m.role for m in msgs] == ["system", "user"]
    assert "`pick`" in msgs[0].text and "during" in msgs[0].text and "proactive" in msgs[0].text
    req = extract_request(msgs[1].text)
    assert req["instruction"] == "stack" and req["objects"] == OBJECTS
    assert req["previous_subgoal"]["action"] == {"skill": "pick", "args": {"obj": "red_block"}}
    assert req["feedback"] == "red_block dropped"
    # both views in one low-detail image, front above top, and the text says so
    assert [(im.label, im.detail, im.rgb.shape) for im in msgs[1].images] == [("front+top", "low", (8, 4, 3))]
    assert (msgs[1].images[0].rgb[:4] == 0).all() and (msgs[1].images[0].rgb[4:] == 1).all()
    assert "'front', 'top', top to bottom" in msgs[1].text
    # said once: the request is the whole user text (no prose copy of it)
    assert msgs[1].text.count("red_block dropped") == 1 and msgs[1].text.count("stack") == 1


def test_generator_views_fit_the_low_detail_view():
    be = Scripted(json.dumps(ANSWER))
    gen = ConstraintGenerator(be, skills={"pick": "args {obj}: pick it up"})
    big = np.zeros((480, 1024, 3), np.uint8)
    gen.next_subgoal("stack", {"front": big, "top": np.zeros((240, 320, 3), np.uint8)}, OBJECTS)
    msgs = be.calls[0][0]
    # stacked (720 x 1024) then scaled down to fit 512 x 512, one image at detail low
    assert [(im.rgb.shape, im.detail) for im in msgs[1].images] == [((360, 512, 3), "low")]
    assert "`pick`" in msgs[0].text and "`place_on`" not in msgs[0].text  # only the policy's skills


def test_generator_reasks_then_raises():
    bad = json.dumps({**ANSWER, "action": {"skill": "pick", "args": {}}, "constraints": []})
    be = Scripted(bad, "not json", json.dumps(ANSWER))
    gen = ConstraintGenerator(be, max_retries=2)
    assert gen.next_subgoal("stack", {}, OBJECTS).action.skill == "pick"
    assert len(be.calls) == 3
    last_msgs = be.calls[2][0]
    # a re-ask carries the request, the last answer and its error (not the first answer: no growing conversation)
    assert [m.role for m in last_msgs] == ["system", "user", "assistant", "user"]
    assert last_msgs[2].text == "not json" and "no JSON object" in last_msgs[3].text
    assert "at least one constraint" in be.calls[1][0][3].text
    gen = ConstraintGenerator(Scripted("x", "y"), max_retries=1)
    with pytest.raises(VLMOutputError, match="after 2 attempt"):
        gen.next_subgoal("stack", {}, OBJECTS)
    assert gen.usage.calls == 2 and gen.usage.per_subgoal()[0]["prompt_tokens"] == 20
    with pytest.raises(ConfigError):
        ConstraintGenerator(be, max_retries=-1)


def _subgoal() -> Subgoal:
    tip = ElementSpec("tip", "robot", "tip", "point")
    g = ElementSpec("green", "green_block", "", "point")
    r = ElementSpec("red", "red_block", "", "point")
    return Subgoal("place green on red", [
        Constraint("attached", "green stays attached", "during", [tip, g]),
        Constraint("centred", "green centred on red", "upon", [g, r], proactive=True),
    ], Action("place_on", {"obj": "green_block", "target": "red_block"}))


def _elements(sg: Subgoal) -> list[Element]:
    specs = legend_specs(sg)
    return [Element(i, s.name, s.kind, np.full((1, 3), float(i)), (s.obj, s.part)) for i, s in enumerate(specs)]


GOOD_PROGRAM = """```python
def check_attached(E, H, t):
    return True, "ok"


def check_centred(E, H, t):
    return True, "ok", 0.01
```"""


def test_legend_order_and_id_resolution():
    sg = _subgoal()
    assert [(s.obj, s.part) for s in legend_specs(sg)] == [("robot", "tip"), ("green_block", ""), ("red_block", "")]
    els = _elements(sg)
    assert resolve_element_ids(sg, els) == {"attached": [0, 1], "centred": [1, 2]}
    shuffled = [Element(5 - e.id, e.name, e.kind, e.points, e.owner) for e in els]
    assert resolve_element_ids(sg, shuffled) == {"attached": [5, 4], "centred": [4, 3]}
    sg.constraints[0].element_ids = [2, 1]  # painter-filled ids win
    assert resolve_element_ids(sg, els)["attached"] == [2, 1]
    with pytest.raises(ConfigError, match="no element for part red_block"):
        resolve_element_ids(_subgoal(), els[:2])


def test_coder_request_and_reasks():
    sg = _subgoal()
    els = _elements(sg)
    be = Scripted("```python\ndef check_attached(E, H, t)\n```", "def check_attached(E, H, t):\n    return True, 'x'\n",
                  GOOD_PROGRAM)
    coder = MonitorCoder(be)
    src = coder.write_program(sg, els, {"front": np.zeros((2, 2, 3), np.uint8)}, basic_check(["attached", "centred"]),
                              feedback="branch never reached")
    assert src.startswith("def check_attached") and "```" not in src
    first, purpose = be.calls[0]
    assert purpose == "monitor_coder"
    req = extract_request(first[1].text)
    assert [c["element_ids"] for c in req["constraints"]] == [[0, 1], [1, 2]]
    assert "parts" not in req["constraints"][0]  # the legend says what each element is, once
    # names that only repeat the owner's words are left out
    assert req["elements"] == [[0, "point", "robot/tip"], [1, "point", "green_block"], [2, "point", "red_block"]]
    assert "action" not in req and "proactive" not in req["constraints"][1]  # not what a program computes
    assert req["feedback"] == "branch never reached" and first[1].text.count("branch never reached") == 1
    assert [(im.label, im.detail) for im in first[1].images] == [("front", "low")]
    assert "syntax error" in be.calls[1][0][-1].text
    assert "missing function check_centred" in be.calls[2][0][-1].text


def test_legend_rows_name_an_element_only_when_its_owner_does_not_say_it():
    from code_as_monitor.planning.coder import legend_row

    def row(name: str, owner: tuple[str, str]) -> list:
        return legend_row(Element(3, name, ElementKind.POINT, np.zeros((1, 3)), owner))

    assert row("suction cup tip", ("robot", "tip")) == [3, "point", "robot/tip", "suction cup tip"]
    assert row("book centre", ("book", "cover")) == [3, "point", "book/cover", "book centre"]
    assert row("bookshelf slot", ("bookshelf", "slot")) == [3, "point", "bookshelf/slot"]
    assert row("Green block", ("green_block", "")) == [3, "point", "green_block"]


def test_coder_views_lossless_and_one_image_when_they_fit():
    sg = _subgoal()
    coder = MonitorCoder(Scripted(GOOD_PROGRAM))
    small = {"front": np.zeros((240, 320, 3), np.uint8), "top": np.full((240, 300, 3), 7, np.uint8)}
    msgs = coder.build_messages(sg, _elements(sg), small)
    [im] = msgs[1].images  # 480 x 320 fits the low-detail view: one image, every pixel kept
    assert im.detail == "low" and im.rgb.shape == (480, 320, 3)
    assert (im.rgb[240:, :300] == 7).all() and (im.rgb[240:, 300:] == 0).all()
    big = {"front": np.zeros((480, 640, 3), np.uint8), "top": np.zeros((240, 320, 3), np.uint8)}
    msgs = coder.build_messages(sg, _elements(sg), big)  # too big to stack losslessly: each on its own
    assert [(im.label, im.detail, im.rgb.shape) for im in msgs[1].images] == [
        ("front", "high", (480, 640, 3)), ("top", "low", (240, 320, 3))]


def test_coder_without_views_sends_the_request_alone_and_says_so():
    sg = _subgoal()
    small = {"front": np.zeros((240, 320, 3), np.uint8)}
    with_views = MonitorCoder(Scripted(GOOD_PROGRAM)).build_messages(sg, _elements(sg), small)
    without = MonitorCoder(Scripted(GOOD_PROGRAM), views=False).build_messages(sg, _elements(sg), small)
    assert len(with_views[1].images) == 1 and "Image:" in with_views[0].text
    assert not without[1].images and "Image:" not in without[0].text
    assert without[1].text == with_views[1].text.split("\nView")[0]  # the same request, no view label


def test_coder_reuses_an_accepted_program_for_the_same_request():
    sg = _subgoal()
    els = _elements(sg)
    be = Scripted(GOOD_PROGRAM, GOOD_PROGRAM.replace('"ok"', '"fine"'))
    coder = MonitorCoder(be)
    checked: list[str] = []

    def check(source: str) -> None:
        checked.append(source)

    first = coder.write_program(sg, els, {}, check)
    again = coder.write_program(sg, els, {"front": np.zeros((2, 2, 3), np.uint8)}, check)
    assert again == first and len(be.calls) == 1 and coder.reused == 1 and checked == [first, first]
    assert coder.usage.calls == 1
    # another threshold is another request: the model is asked
    sg2 = _subgoal()
    sg2.constraints[1].thresholds = {"max_offset": 0.02}
    assert coder.write_program(sg2, els, {}, check) != first and len(be.calls) == 2


def test_coder_asks_again_when_the_kept_program_fails_its_check():
    sg = _subgoal()
    els = _elements(sg)
    be = Scripted(GOOD_PROGRAM, GOOD_PROGRAM, GOOD_PROGRAM)
    coder = MonitorCoder(be)
    coder.write_program(sg, els, {}, basic_check(["attached", "centred"]))

    def reject_once(source: str, seen: list[int] = [0]) -> None:  # noqa: B006 - a counter across calls
        seen[0] += 1
        if seen[0] == 1:
            raise ProgramError("branch never reached")

    coder.write_program(sg, els, {}, reject_once)
    assert len(be.calls) == 2 and coder.reused == 0  # the kept one was re-checked, failed, and dropped
    coder.write_program(sg, els, {}, basic_check(["attached", "centred"]), feedback="x")
    assert len(be.calls) == 3  # a regeneration with feedback never takes a kept program
    assert not MonitorCoder(Scripted()).reused


def test_coder_gives_up_with_a_specific_error():
    sg = _subgoal()

    def reject(source: str) -> None:
        raise ProgramError("line 1: 'while' loops are not allowed")

    coder = MonitorCoder(Scripted(GOOD_PROGRAM, GOOD_PROGRAM))
    with pytest.raises(VLMOutputError, match=r"after 2 attempt.*while"):
        coder.write_program(sg, _elements(sg), {}, reject, max_retries=1)
    with pytest.raises(ConfigError, match="no constraints"):
        coder.write_program(Subgoal("idle"), [], {}, reject)


def test_coder_does_not_resend_a_request_it_just_had_answered():
    """A re-ask answered with the same program, rejected with the same error, is not asked a third time: the
    third request would be word for word the second."""
    sg = _subgoal()

    def reject(source: str) -> None:
        raise ProgramError("'during' checks that already fail on the starting state: check_attached")

    be = Scripted(GOOD_PROGRAM, GOOD_PROGRAM, GOOD_PROGRAM)
    with pytest.raises(VLMOutputError, match=r"after 2 attempt.*already fail"):
        MonitorCoder(be).write_program(sg, _elements(sg), {}, reject, max_retries=2)
    assert len(be.calls) == 2
    other = GOOD_PROGRAM.replace('"ok"', '"fine"')
    be = Scripted(GOOD_PROGRAM, other, other)  # a changed answer earns the next re-ask
    with pytest.raises(VLMOutputError, match=r"after 3 attempt"):
        MonitorCoder(be).write_program(sg, _elements(sg), {}, reject, max_retries=2)
    assert len(be.calls) == 3


def test_program_defines_checks():
    program_defines_checks("def check_a(E, H, t):\n    return True, ''\n", ["a"])
    with pytest.raises(ProgramError, match="missing function check_b"):
        program_defines_checks("def check_a(E, H, t):\n    pass\n", ["a", "b"])
    with pytest.raises(ProgramError, match=r"exactly \(E, H, t\)"):
        program_defines_checks("def check_a(E, H):\n    pass\n", ["a"])
    with pytest.raises(ProgramError, match="syntax error at line 1"):
        program_defines_checks("def (", ["a"])
