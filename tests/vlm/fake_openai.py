"""A scripted OpenAI-compatible ``/v1/chat/completions`` server on 127.0.0.1 (a real HTTP server: the
``openai`` SDK talks to it over a socket), answering plain or streamed (server-sent events) requests.

Each request pops the next step of ``script``: a dict with ``status`` (default 200), ``message`` (the error
text for a non-200 status), ``content`` (answer text), ``finish_reason`` (default "stop"), ``delay`` (seconds
before answering), ``chunk_delay`` (seconds between streamed chunks), ``headers`` and ``usage``
({prompt_tokens, completion_tokens}; None sends no usage). ``disconnects`` counts streamed answers the client
closed before their end (what a real server sees when a request is given up).
"""

from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any


class FakeServer:
    def __init__(self) -> None:
        self.script: list[dict[str, Any]] = []
        self.requests: list[dict[str, Any]] = []
        self.headers: list[dict[str, str]] = []
        self.disconnects = 0
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
                try:
                    if step.get("status", 200) != 200:
                        self._error(step)
                    elif body.get("stream"):
                        self._stream(body, step)
                    else:
                        self._plain(body, step)
                except OSError:  # the client gave up
                    with server.lock:
                        server.disconnects += 1

            def _send(self, status: int, data: bytes, ctype: str, headers: dict[str, str]) -> None:
                self.send_response(status)
                self.send_header("Content-Type", ctype)
                if ctype == "application/json":
                    self.send_header("Content-Length", str(len(data)))
                for k, v in headers.items():
                    self.send_header(k, v)
                self.end_headers()
                self.wfile.write(data)
                self.wfile.flush()

            def _error(self, step: dict[str, Any]) -> None:
                status = step["status"]
                msg = step.get("message", f"scripted {status}")
                data = json.dumps({"error": {"message": msg, "type": "test", "code": status}}).encode()
                self._send(status, data, "application/json", step.get("headers", {}))

            def _usage(self, step: dict[str, Any]) -> dict[str, int] | None:
                usage = step.get("usage", {"prompt_tokens": 11, "completion_tokens": 7})
                return None if usage is None else {**usage, "total_tokens": sum(usage.values())}

            def _plain(self, body: dict[str, Any], step: dict[str, Any]) -> None:
                payload = {"id": "chatcmpl-test", "object": "chat.completion", "created": 0,
                           "model": body.get("model", "m"),
                           "choices": [{"index": 0, "finish_reason": step.get("finish_reason", "stop"),
                                        "message": {"role": "assistant", "content": step.get("content", "")}}]}
                usage = self._usage(step)
                if usage is not None:
                    payload["usage"] = usage
                self._send(200, json.dumps(payload).encode(), "application/json", step.get("headers", {}))

            def _stream(self, body: dict[str, Any], step: dict[str, Any]) -> None:
                self._send(200, b"", "text/event-stream", step.get("headers", {}))
                text = step.get("content", "")
                pieces = [text[i: i + 16] for i in range(0, len(text), 16)] or [""]
                base = {"id": "chatcmpl-test", "object": "chat.completion.chunk", "created": 0,
                        "model": body.get("model", "m")}
                for i, piece in enumerate(pieces):
                    last = i == len(pieces) - 1
                    chunk = {**base, "choices": [{"index": 0, "delta": {"content": piece},
                                                  "finish_reason": step.get("finish_reason", "stop") if last
                                                  else None}]}
                    self.wfile.write(f"data: {json.dumps(chunk)}\n\n".encode())
                    self.wfile.flush()
                    time.sleep(step.get("chunk_delay", 0.0))
                usage = self._usage(step)
                if usage is not None and (body.get("stream_options") or {}).get("include_usage"):
                    self.wfile.write(f"data: {json.dumps({**base, 'choices': [], 'usage': usage})}\n\n".encode())
                self.wfile.write(b"data: [DONE]\n\n")
                self.wfile.flush()

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True)
        self.thread.start()
        self.base_url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
