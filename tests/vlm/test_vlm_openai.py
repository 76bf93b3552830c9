"""The ``openai`` backend through the real SDK against a scripted OpenAI-compatible server on 127.0.0.1
(``fake_openai.py``): streaming, structured outputs, errors named with their fix, bounded retries, repairs."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator

import numpy as np
import pytest
from fake_openai import FakeServer

from code_as_monitor.core.errors import (
    VLMConfigError,
    VLMContextError,
    VLMError,
    VLMImageError,
    VLMOutputError,
    VLMRequestError,
    VLMTimeoutError,
)
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check
from code_as_monitor.vlm.backend import OpenAIBackendConfig, make_backend
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.messages import Message

STACK = "stack the blocks: red at the bottom, then green, then blue"
OBJECTS = ["red_block", "green_block", "blue_block", "table"]


@pytest.fixture
def server() -> Iterator[FakeServer]:
    s = FakeServer()
    yield s
    s.close()


@pytest.fixture
def backend(server: FakeServer, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setenv("CAM_TEST_KEY", "test-key")

    def make(**kw):
        cfg = {"model": "test-model", "base_url": server.base_url, "api_key_env": "CAM_TEST_KEY",
               "timeout_s": 2.0, "max_retries": 2, "backoff_base_s": 0.01, **kw}
        return make_backend(OpenAIBackendConfig(**cfg))

    return make


def kb_answer(messages: list[Message], purpose: str) -> str:
    """A valid answer for ``messages`` (what a good model would say), from the kb."""
    return KBBackend().complete(messages, purpose=purpose).text


def test_normal_answer_with_images_and_usage(server, backend):
    server.script = [{"content": "hello", "usage": {"prompt_tokens": 123, "completion_tokens": 45}}]
    img = np.zeros((4, 5, 3), np.uint8)
    img[0, 0] = (255, 0, 0)
    msgs = [Message.system("be brief"), Message.user("look", {"front": img})]
    resp = backend().complete(msgs, purpose="test")
    assert (resp.text, resp.prompt_tokens, resp.completion_tokens, resp.model) == ("hello", 123, 45, "test-model")
    assert not resp.estimated
    req = server.requests[0]
    assert req["model"] == "test-model"
    assert req["messages"][0] == {"role": "system", "content": "be brief"}
    parts = req["messages"][1]["content"]
    assert [p["type"] for p in parts] == ["text", "text", "image_url"]
    assert parts[2]["image_url"]["url"].startswith("data:image/png;base64,")
    assert {k.lower(): v for k, v in server.headers[0].items()}["authorization"] == "Bearer test-key"


def test_429_then_success_honours_retry_after(server, backend):
    server.script = [{"status": 429, "headers": {"Retry-After": "0"}}, {"content": "ok"}]
    t0 = time.monotonic()
    resp = backend(backoff_base_s=5.0).complete([Message.user("hi")], purpose="test")
    assert resp.text == "ok" and len(server.requests) == 2
    assert time.monotonic() - t0 < 2.0  # Retry-After: 0 beat the 5 s exponential backoff


def test_500_storm_ends_in_a_clear_error(server, backend):
    server.script = [{"status": 500}] * 3 + [{"content": "too late"}]
    with pytest.raises(VLMError, match=r"gave up after 3 attempt\(s\): HTTP 500"):
        backend(max_retries=2).complete([Message.user("hi")], purpose="test")
    assert len(server.requests) == 3


def test_timeout_closes_the_request_and_is_not_retried(server, backend):
    server.script = [{"content": "x" * 800, "chunk_delay": 0.05}, {"content": "never asked"}]
    t0 = time.monotonic()
    with pytest.raises(VLMTimeoutError, match=r"no answer within 0\.3 s.*--timeout"):
        backend(timeout_s=0.3, max_retries=2).complete([Message.user("hi")], purpose="test")
    assert time.monotonic() - t0 < 1.5
    for _ in range(100):  # the server notices the closed stream at its next writes
        if server.disconnects:
            break
        time.sleep(0.02)
    assert server.disconnects == 1 and len(server.requests) == 1


def test_plain_requests_without_streaming(server, backend):
    server.script = [{"content": "plain", "usage": {"prompt_tokens": 5, "completion_tokens": 2}}]
    resp = backend(stream=False).complete([Message.user("hi")], purpose="test")
    assert (resp.text, resp.prompt_tokens, resp.estimated) == ("plain", 5, False)
    assert "stream" not in server.requests[0] or not server.requests[0]["stream"]


def test_a_server_without_usage_gives_estimates(server, backend):
    server.script = [{"content": "no usage here", "usage": None}]
    resp = backend().complete([Message.user("hi")], purpose="test")
    assert resp.text == "no usage here" and resp.estimated and resp.prompt_tokens > 0


def test_client_errors_are_not_retried(server, backend):
    server.script = [{"status": 400}, {"content": "never"}]
    with pytest.raises(VLMRequestError, match="HTTP 400"):
        backend().complete([Message.user("hi")], purpose="test")
    assert len(server.requests) == 1
    server.script = [{"status": 401}]
    with pytest.raises(VLMConfigError, match="rejected the API key from CAM_TEST_KEY"):
        backend().complete([Message.user("hi")], purpose="test")
    server.script = [{"status": 404, "message": "model 'nope' not found"}]
    with pytest.raises(VLMConfigError, match="check --model"):
        backend().complete([Message.user("hi")], purpose="test")


@pytest.mark.parametrize("status,message", [
    (500, "image input is not supported - hint: if this is unexpected, you may need to provide the mmproj"),
    (400, "Invalid content part type: image_url"),
    (400, "this model does not support vision"),
])
def test_a_model_without_images_is_named_with_the_fix_and_not_retried(server, backend, status, message):
    server.script = [{"status": status, "message": message}] * 3
    img = np.zeros((4, 4, 3), np.uint8)
    with pytest.raises(VLMImageError, match=r"does not accept images.*--no-images"):
        backend().complete([Message.user("look", {"front": img})], purpose="test")
    assert len(server.requests) == 1


def test_no_images_sends_text_only(server, backend):
    server.script = [{"content": "ok"}]
    img = np.zeros((4, 4, 3), np.uint8)
    backend(images=False).complete([Message.user("look", {"front": img})], purpose="test")
    content = server.requests[0]["messages"][0]["content"]
    assert isinstance(content, str) and "look" in content and "(image front not sent)" in content


@pytest.mark.parametrize("status,message", [
    (400, "the request exceeds the available context size, try increasing it"),
    (400, "This model's maximum context length is 2048 tokens. However, you requested 3100 tokens"),
    (500, "requested tokens (3000) exceed context window of 2048"),
])
def test_a_context_too_small_is_named_with_the_fix(server, backend, status, message):
    server.script = [{"status": status, "message": message}] * 3
    with pytest.raises(VLMContextError, match=r"context.*(--ctx-size|--n_ctx).*--max-tokens \(now 512\)"):
        backend(max_tokens=512).complete([Message.user("hi")], purpose="test")
    assert len(server.requests) == 1


def test_a_cut_off_answer_is_an_error_naming_max_tokens(server, backend):
    server.script = [{"content": '{"subgoal": "pick up the gre', "finish_reason": "length"}]
    with pytest.raises(VLMContextError, match=r"cut off at max_tokens=64.*raise --max-tokens"):
        backend(max_tokens=64).complete([Message.user("hi")], purpose="test")


def test_structured_output_asks_the_schema_and_falls_back_once(server, backend):
    schema = {"title": "GeneratorOutput", "type": "object", "properties": {"subgoal": {"type": "string"}}}
    be = backend()
    refusal = "1 validation error: {'loc': ('body', 'response_format', 'type'), 'msg': 'Input should be text'}"
    server.script = [{"status": 500, "message": refusal},  # how llama-cpp-python refuses json_schema
                     {"status": 422, "message": "unsupported response_format: json_object"},
                     {"content": "first"}, {"content": "second"}]
    assert be.complete([Message.user("hi")], purpose="test", schema=schema).text == "first"
    assert be.complete([Message.user("hi")], purpose="test", schema=schema).text == "second"
    fmts = [r.get("response_format") for r in server.requests]
    assert fmts[0] == {"type": "json_schema", "json_schema": {"name": "GeneratorOutput", "schema": schema,
                                                              "strict": False}}
    assert fmts[1] == {"type": "json_object", "schema": schema}
    assert fmts[2] is None and fmts[3] is None  # the refused formats are not asked again
    server.script = [{"status": 400, "message": "response_format json_schema not supported"}]
    with pytest.raises(VLMRequestError, match=r"structured output json_schema.*--structured auto or off"):
        backend(structured="json_schema").complete([Message.user("hi")], purpose="test", schema=schema)


def test_a_server_refusing_stream_options_is_asked_without(server, backend):
    server.script = [{"status": 400, "message": "Unrecognized request argument supplied: stream_options"},
                     {"content": "ok"}]
    assert backend().complete([Message.user("hi")], purpose="test").text == "ok"
    assert "stream_options" in server.requests[0] and "stream_options" not in server.requests[1]


def test_missing_api_key_names_the_variable(monkeypatch):
    monkeypatch.delenv("CAM_UNSET_KEY", raising=False)
    with pytest.raises(VLMConfigError, match="CAM_UNSET_KEY is not set"):
        make_backend(OpenAIBackendConfig(api_key_env="CAM_UNSET_KEY", base_url="http://127.0.0.1:1/v1"))


def test_keyless_local_server(server, monkeypatch):
    server.script = [{"content": "local"}]
    be = make_backend(OpenAIBackendConfig(model="m", base_url=server.base_url, api_key_env="none"))
    assert be.complete([Message.user("hi")], purpose="test").text == "local"


def test_malformed_json_repaired_on_second_ask(server, backend):
    gen = ConstraintGenerator(backend())
    good = kb_answer(gen.build_messages(STACK, {}, OBJECTS, None, None), "constraint_generator")
    server.script = [{"content": '```json\n{"subgoal": "pick up the green block", "done": false,\n```'},
                     {"content": good, "usage": {"prompt_tokens": 1000, "completion_tokens": 300}}]
    sg = gen.next_subgoal(STACK, {}, OBJECTS)
    assert sg.action.to_dict() == {"skill": "pick", "args": {"obj": "green_block"}}
    assert len(server.requests) == 2
    second = server.requests[1]["messages"]
    assert second[-2]["role"] == "assistant" and "invalid JSON" in second[-1]["content"]
    assert server.requests[0]["response_format"]["json_schema"]["schema"]["title"] == "GeneratorOutput"
    ep = gen.usage.episode()
    assert (ep["calls"], ep["prompt_tokens"], ep["completion_tokens"]) == (2, 1011, 307)


def test_repairs_send_the_last_answer_and_error_not_the_conversation(server, backend):
    answers = ['{"subgoal": "a"', '{"subgoal": "b", "done": false', '{"subgoal": "c"']
    server.script = [{"content": a} for a in answers]
    gen = ConstraintGenerator(backend(), max_retries=2)
    with pytest.raises(VLMOutputError):
        gen.next_subgoal(STACK, {}, OBJECTS)
    sizes = [len(json.dumps(r["messages"])) for r in server.requests]
    roles = [[m["role"] for m in r["messages"]] for r in server.requests]
    assert roles[1] == roles[2] == ["system", "user", "assistant", "user"]
    assert server.requests[2]["messages"][2]["content"] == answers[1]  # the last answer, not the first
    assert abs(sizes[2] - sizes[1]) < 100  # the prompt does not grow with each repair


def test_answer_that_never_validates(server, backend):
    bad = json.dumps({"subgoal": "pick", "done": False, "action": {"skill": "fly", "args": {}},
                      "constraints": [{"id": "c1", "text": "t", "phase": "sometimes", "parts": []}]})
    server.script = [{"content": bad}] * 3
    gen = ConstraintGenerator(backend(), max_retries=2)
    with pytest.raises(VLMOutputError, match="no valid answer after 3 attempt") as info:
        gen.next_subgoal(STACK, {}, OBJECTS)
    assert "unknown skill 'fly'" in str(info.value) and "phase" in str(info.value)
    assert len(server.requests) == 3 and gen.usage.calls == 3


def test_monitor_coder_reasks_after_a_bad_program(server, backend):
    kb_gen = ConstraintGenerator(KBBackend())
    sg = kb_gen.next_subgoal(STACK, {}, OBJECTS)
    from code_as_monitor.core import Element

    els = [Element.point(0, "suction cup tip", [0.5, 0, 0.1], ("robot", "tip")),
           Element.point(1, "green block", [0.5, 0, 0.02], ("green_block", "")),
           Element.point(2, "red block", [0.4, 0.2, 0.02], ("red_block", "")),
           Element.point(3, "blue block", [0.6, -0.2, 0.02], ("blue_block", ""))]
    coder = MonitorCoder(backend())
    good = kb_answer(coder.build_messages(sg, els, {}), "monitor_coder")
    server.script = [{"content": "```python\ndef check_something(E, H, t):\n    return True, 'x'\n```"},
                     {"content": good}]
    src = coder.write_program(sg, els, {}, basic_check([c.id for c in sg.constraints]))
    assert "def check_held_green_block(E, H, t):" in src and "```" not in src
    assert "missing function check_held_green_block" in server.requests[1]["messages"][-1]["content"]
    assert server.requests[0]["response_format"]["json_schema"]["schema"]["required"] == ["program"]


def test_monitor_coder_reads_a_structured_program(server, backend):
    sg = ConstraintGenerator(KBBackend()).next_subgoal(STACK, {}, OBJECTS)
    from code_as_monitor.core import Element

    els = [Element.point(0, "suction cup tip", [0.5, 0, 0.1], ("robot", "tip")),
           Element.point(1, "green block", [0.5, 0, 0.02], ("green_block", "")),
           Element.point(2, "red block", [0.4, 0.2, 0.02], ("red_block", "")),
           Element.point(3, "blue block", [0.6, -0.2, 0.02], ("blue_block", ""))]
    coder = MonitorCoder(backend())
    good = kb_answer(coder.build_messages(sg, els, {}), "monitor_coder")
    server.script = [{"content": json.dumps({"program": good})}]
    src = coder.write_program(sg, els, {}, basic_check([c.id for c in sg.constraints]))
    assert "def check_held_green_block(E, H, t):" in src and "```" not in src


def test_the_server_gets_the_lean_prompts_with_their_images_and_details(server, backend):
    import base64

    import cv2

    from code_as_monitor.core import Element
    from code_as_monitor.planning.coder import legend_row, legend_specs

    front = np.zeros((240, 320, 3), np.uint8)
    front[0, 0] = (255, 0, 0)
    top = np.full((240, 320, 3), 9, np.uint8)
    gen = ConstraintGenerator(backend(image_detail="high"))
    good = kb_answer(gen.build_messages(STACK, {"front": front, "top": top}, OBJECTS, None, None),
                     "constraint_generator")
    server.script = [{"content": good}]
    sg = gen.next_subgoal(STACK, {"front": front, "top": top}, OBJECTS)
    [system, user] = server.requests[0]["messages"]
    assert "`pick`" in system["content"] and '"parts"' in system["content"]
    texts = [p["text"] for p in user["content"] if p["type"] == "text"]
    assert STACK in texts[0] and "```json request" in texts[0] and "'front', 'top', top to bottom" in texts[1]
    [image] = [p["image_url"] for p in user["content"] if p["type"] == "image_url"]
    assert image["detail"] == "low"  # the part's own detail wins over the backend's "high"
    png = base64.b64decode(image["url"].split(",", 1)[1])
    sent = cv2.cvtColor(cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    assert sent.shape == (480, 320, 3) and tuple(sent[0, 0]) == (255, 0, 0) and (sent[240:] == 9).all()

    els = [Element(i, p.name, p.kind, np.zeros((1 if p.kind.value == "point" else 2, 3)), (p.obj, p.part))
           for i, p in enumerate(legend_specs(sg))]
    coder = MonitorCoder(backend())
    server.script = [{"content": kb_answer(coder.build_messages(sg, els, {"front": front}), "monitor_coder")}]
    coder.write_program(sg, els, {"front": front}, basic_check([c.id for c in sg.constraints]))
    user = server.requests[1]["messages"][1]["content"]
    assert [p["image_url"]["detail"] for p in user if p["type"] == "image_url"] == ["low"]
    legend = json.dumps([legend_row(e) for e in els], separators=(",", ":"))
    assert f'"elements":{legend}' in user[0]["text"]
