"""``cam plan``: kb plan, an OpenAI-compatible server, replay, and one-line errors with exit 2."""

from __future__ import annotations

import json
import socket
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from code_as_monitor.cli.main import main
from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects
from code_as_monitor.vlm.kb.registry import all_thresholds

STACK = "stack the blocks: red at the bottom, then green, then blue"


def test_plan_kb_prints_subgoals_and_constraints(capsys):
    assert main(["plan", STACK, "--backend", "kb"]) == 0
    out = capsys.readouterr().out
    assert "a rule-based stand-in for a VLM (not a VLM)" in out
    for line in ("1. pick up the green block  [pick obj=green_block]",
                 "2. place the green block on the red block  [place_on obj=green_block target=red_block]",
                 "3. pick up the blue block", "4. place the blue block on the green block", "5. task complete"):
        assert line in out
    assert "during attached_green_block (reactive)" in out
    assert "upon   centred_green_block_on_red_block (proactive)" in out
    assert f"max_offset={all_thresholds()['centred']['max_offset']:g}" in out and "usage: 5 calls" in out


def test_plan_kb_json_with_code(capsys):
    assert main(["plan", "use the rope to close the opening of the square", "--json", "--code"]) == 0
    doc = json.loads(capsys.readouterr().out)
    first = doc["plan"][0]
    assert first["action"] == {"skill": "close_shape", "args": {"rope": "rope", "shape": "square"}}
    assert "def check_rope_covers_opening(E, H, t):" in first["program"]
    assert doc["plan"][-1]["done"] and doc["usage"]["episode"]["calls_by_purpose"]["monitor_coder"] == 1


def test_plan_record_then_replay(tmp_path, capsys):
    cas = tmp_path / "plan.jsonl"
    assert main(["plan", STACK, "--record", str(cas)]) == 0
    recorded = capsys.readouterr().out
    assert main(["plan", STACK, "--backend", "replay", "--cassette", str(cas)]) == 0
    replayed = capsys.readouterr().out
    strip = lambda s: s.split("\n", 1)[1]  # noqa: E731  (the backend line differs)
    assert strip(replayed) == strip(recorded)
    assert main(["plan", "stack the blocks: blue at the bottom, then red", "--backend", "replay",
                 "--cassette", str(cas)]) == 2
    err = capsys.readouterr().err
    assert "no entry for request" in err and len(err.strip().splitlines()) == 1


class _Server:
    """Minimal OpenAI-compatible server answering every request with ``answer`` (streamed when asked), or with
    HTTP ``error`` (status, message) when set."""

    def __init__(self, answer: str) -> None:
        outer = self
        self.image_counts: list[int] = []
        self.bodies: list[dict] = []
        self.error: tuple[int, str] | None = None

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: object) -> None:
                pass

            def do_POST(self) -> None:
                body = json.loads(self.rfile.read(int(self.headers.get("Content-Length", 0))))
                outer.bodies.append(body)
                parts = [p for m in body["messages"] if isinstance(m["content"], list) for p in m["content"]]
                outer.image_counts.append(sum(p["type"] == "image_url" for p in parts))
                usage = {"prompt_tokens": 321, "completion_tokens": 54, "total_tokens": 375}
                if outer.error is not None:
                    data = json.dumps({"error": {"message": outer.error[1]}}).encode()
                    self.send_response(outer.error[0])
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    self.end_headers()
                    self.wfile.write(data)
                    return
                if body.get("stream"):
                    base = {"id": "x", "object": "chat.completion.chunk", "created": 0, "model": "local-model"}
                    choice = {"index": 0, "delta": {"content": answer}, "finish_reason": "stop"}
                    events = [{**base, "choices": [choice]}, {**base, "choices": [], "usage": usage}]
                    self.send_response(200)
                    self.send_header("Content-Type", "text/event-stream")
                    self.end_headers()
                    for ev in events:
                        self.wfile.write(f"data: {json.dumps(ev)}\n\n".encode())
                    self.wfile.write(b"data: [DONE]\n\n")
                    return
                data = json.dumps({
                    "id": "x", "object": "chat.completion", "created": 0, "model": "local-model",
                    "choices": [{"index": 0, "finish_reason": "stop",
                                 "message": {"role": "assistant", "content": answer}}],
                    "usage": usage,
                }).encode()
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True).start()
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def server():
    gen = ConstraintGenerator(KBBackend())
    answer = KBBackend().complete(gen.build_messages(STACK, {}, infer_objects(STACK), None, None),
                                  purpose="constraint_generator").text
    s = _Server(answer)
    yield s
    s.close()


def test_plan_openai_against_a_local_server(server, capsys, monkeypatch):
    monkeypatch.setenv("CAM_PLAN_KEY", "k")
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", server.url, "--model", "local-model",
               "--api-key-env", "CAM_PLAN_KEY"])
    out = capsys.readouterr().out
    assert rc == 0
    assert f"backend: openai: local-model at {server.url}" in out
    assert "1. pick up the green block  [pick obj=green_block]" in out and "2." not in out
    assert "usage: 1 calls (constraint_generator 1), 321 prompt + 54 completion tokens" in out
    assert "estimated" not in out


def test_plan_openai_sends_images(server, capsys, tmp_path):
    import cv2
    import numpy as np

    path = tmp_path / "front.png"
    cv2.imwrite(str(path), np.full((6, 8, 3), 200, np.uint8))
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", server.url, "--api-key-env", "none",
               "--image", str(path), "--image", f"top={path}"])
    assert rc == 0 and "1. pick up the green block" in capsys.readouterr().out
    assert server.image_counts == [1]  # both small views stacked into one low-detail image


def test_plan_openai_server_options_reach_the_request(server, capsys):
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", server.url, "--api-key-env", "none",
               "--max-tokens", "1500", "--timeout", "30", "--structured", "off"])
    assert rc == 0 and "1. pick up the green block" in capsys.readouterr().out
    body = server.bodies[0]
    assert body["max_tokens"] == 1500 and "response_format" not in body and body["stream"] is True
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", server.url, "--api-key-env", "none"])
    assert rc == 0 and server.bodies[1]["response_format"]["type"] == "json_schema"
    capsys.readouterr()
    assert main(["plan", STACK, "--timeout", "5"]) == 2  # a server option for the kb
    assert "apply to the openai backend" in capsys.readouterr().err


def test_plan_openai_model_without_images_is_one_line_with_the_fix(server, capsys, tmp_path):
    import cv2
    import numpy as np

    path = tmp_path / "front.png"
    cv2.imwrite(str(path), np.full((6, 8, 3), 200, np.uint8))
    server.error = (500, "image input is not supported - hint: you may need to provide the mmproj")
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", server.url, "--api-key-env", "none",
               "--image", str(path)])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--no-images" in err
    assert len(server.bodies) == 1  # not retried
    server.error = None
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", server.url, "--api-key-env", "none",
               "--image", str(path), "--no-images"])
    assert rc == 0 and server.image_counts[-1] == 0
    assert "(image front not sent)" in server.bodies[-1]["messages"][1]["content"]


def test_plan_openai_missing_key_is_one_line_exit_2(capsys, monkeypatch):
    monkeypatch.delenv("CAM_PLAN_NO_KEY", raising=False)
    rc = main(["plan", STACK, "--backend", "openai", "--api-key-env", "CAM_PLAN_NO_KEY"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "CAM_PLAN_NO_KEY is not set" in err and "Traceback" not in err


def test_plan_openai_unreachable_server_is_one_line_exit_2(capsys):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    rc = main(["plan", STACK, "--backend", "openai", "--base-url", f"http://127.0.0.1:{port}/v1",
               "--api-key-env", "none", "--max-retries", "0", "--timeout", "5"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "cannot connect" in err and "Traceback" not in err


def test_plan_bad_inputs(capsys, tmp_path):
    assert main(["plan", "juggle three oranges"]) == 2
    err = capsys.readouterr().err
    assert "did not understand 'juggle', 'oranges'" in err and len(err.strip().splitlines()) == 1
    assert main(["plan", STACK, "--image", f"front={tmp_path / 'missing.png'}"]) == 2
    assert "cannot read an image" in capsys.readouterr().err
    assert main(["plan", STACK, "--backend", "replay"]) == 2
    assert "needs --cassette" in capsys.readouterr().err
