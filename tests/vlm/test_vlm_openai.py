"""The ``openai`` backend through the real SDK against a scripted OpenAI-compatible server on 127.0.0.1."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest

from code_as_monitor.core.errors import VLMConfigError, VLMError, VLMOutputError
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check
from code_as_monitor.vlm.backend import OpenAIBackendConfig, make_backend
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.messages import Message

STACK = "stack the blocks: red at the bottom, then green, then blue"
OBJECTS = ["red_block", "green_block", "blue_block", "table"]


class FakeServer:
    """A scripted /v1/chat/completions server; each request pops the next step of the script.

    A step is a dict: ``status`` (default 200), ``content`` (answer text), ``delay`` (seconds before
    answering), ``headers``, ``usage`` ({prompt_tokens, completion_tokens}) or ``body`` (raw JSON).
    """

    def __init__(self) -> None:
        self.script: list[dict] = []
        self.requests: list[dict] = []
        self.headers: list[dict] = []
        self.lock = threading.Lock()
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: object) -> None:
                pass

            def do_POST(self) -> None:
                body = json.loads(self.rfile.read(int(self.headers.get("Content-Length", 0))) or b"{}")
                with server.lock:
                    server.requests.append(body)
                    server.headers.append(dict(self.headers))
                    step = server.script.pop(0) if server.script else {"content": "no more script"}
                time.sleep(step.get("delay", 0.0))
                status = step.get("status", 200)
                if status == 200:
                    usage = step.get("usage", {"prompt_tokens": 11, "completion_tokens": 7})
                    payload = step.get("body") or {
                        "id": "chatcmpl-test", "object": "chat.completion", "created": 0,
                        "model": body.get("model", "m"),
                        "choices": [{"index": 0, "finish_reason": "stop",
                                     "message": {"role": "assistant", "content": step.get("content", "")}}],
                        "usage": {**usage, "total_tokens": sum(usage.values())},
                    }
                else:
                    payload = {"error": {"message": f"scripted {status}", "type": "test", "code": status}}
                data = json.dumps(payload).encode()
                try:
                    self.send_response(status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    for k, v in step.get("headers", {}).items():
                        self.send_header(k, v)
                    self.end_headers()
                    self.wfile.write(data)
                except OSError:  # the client gave up (timeout test)
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
        self.thread.start()
        self.base_url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


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


def test_timeout(server, backend):
    server.script = [{"delay": 1.0, "content": "slow"}] * 2
    t0 = time.monotonic()
    with pytest.raises(VLMError, match=r"timed out after 0\.3 s"):
        backend(timeout_s=0.3, max_retries=1).complete([Message.user("hi")], purpose="test")
    assert time.monotonic() - t0 < 1.5


def test_client_errors_are_not_retried(server, backend):
    server.script = [{"status": 400}, {"content": "never"}]
    with pytest.raises(VLMError, match="HTTP 400"):
        backend().complete([Message.user("hi")], purpose="test")
    assert len(server.requests) == 1
    server.script = [{"status": 401}]
    with pytest.raises(VLMConfigError, match="rejected the API key from CAM_TEST_KEY"):
        backend().complete([Message.user("hi")], purpose="test")


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
    ep = gen.usage.episode()
    assert (ep["calls"], ep["prompt_tokens"], ep["completion_tokens"]) == (2, 1011, 307)


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
           Element.point(1, "green block", [0.5, 0, 0.02], ("green_block", ""))]
    coder = MonitorCoder(backend())
    good = kb_answer(coder.build_messages(sg, els, {}), "monitor_coder")
    server.script = [{"content": "```python\ndef check_something(E, H, t):\n    return True, 'x'\n```"},
                     {"content": good}]
    src = coder.write_program(sg, els, {}, basic_check([c.id for c in sg.constraints]))
    assert "def check_held_green_block(E, H, t):" in src and "```" not in src
    assert "missing function check_held_green_block" in server.requests[1]["messages"][-1]["content"]
