"""The http segmenter against a real local HTTP server (stdlib, 127.0.0.1, ephemeral port)."""

from __future__ import annotations

import json
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest
from perception_synth import Box, Scene, render, two_cameras

from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import ConfigError, PerceptionError
from code_as_monitor.perception.segmenters.base import SegmenterConfig, make_segmenter
from code_as_monitor.perception.segmenters.http import decode_mask, decode_png_rgb, encode_png, encode_rle


@pytest.fixture(scope="module")
def view():
    scene = Scene([Box("red_block", np.array([0.0, 0.0, 0.03]), np.array([0.06, 0.06, 0.06]))])
    return render(scene, two_cameras()[0])


@pytest.fixture(scope="module")
def server(view):
    """Serves masks computed from the fixture's ground truth; records the requests it got."""
    requests: list[dict] = []

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args):  # keep the test output clean
            pass

        def _send(self, code: int, obj: dict) -> None:
            data = json.dumps(obj).encode()
            self.send_response(code)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_POST(self):
            body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
            requests.append(body)
            if self.path == "/slow":
                time.sleep(1.0)
                return self._send(200, {"found": False})
            if self.path == "/boom":
                return self._send(500, {"error": "model crashed\nTraceback (most recent call last):\n  ..."})
            rgb = decode_png_rgb(body["image"]["data"])
            if rgb.shape != view.rgb.shape or not np.array_equal(rgb, view.rgb):
                return self._send(400, {"error": "image did not survive the trip"})
            obj, part = body["object"], body["part"]
            known = {o for o, _ in view.seg_labels.values()} | {"green_block"}
            if obj not in known:
                return self._send(404, {"error": f"unknown object {obj!r}"})
            inst = view.mask_of(obj)
            if not inst.any():
                return self._send(200, {"found": False})
            pm = None
            if part:
                pm = {"format": "png", "data": encode_png(view.mask_of(obj, part).astype(np.uint8) * 255)}
            return self._send(200, {"found": True, "instance_mask": encode_rle(inst), "part_mask": pm,
                                    "kind": "surface" if part == "top" else body["kind"], "score": 0.9})

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}", requests
    httpd.shutdown()
    httpd.server_close()


def test_rle_round_trip():
    rng = np.random.default_rng(0)
    for m in (rng.random((7, 9)) > 0.5, np.ones((3, 4), bool), np.zeros((3, 4), bool)):
        np.testing.assert_array_equal(decode_mask(encode_rle(m), m.shape), m)
    with pytest.raises(ValueError, match="sum"):
        decode_mask({"format": "rle", "size": [2, 2], "counts": [1, 1]}, (2, 2))


def test_http_segmenter_masks_from_server(server, view):
    url, requests = server
    seg = make_segmenter(SegmenterConfig.from_name("http", url=f"{url}/segment", send_depth=True))
    res = seg.segment(view, ElementSpec("red top", "red_block", "top", ElementKind.POINT), "keep the top level")
    np.testing.assert_array_equal(res.instance_mask, view.mask_of("red_block"))
    np.testing.assert_array_equal(res.part_mask, view.mask_of("red_block", "top"))
    assert res.kind is ElementKind.SURFACE and res.score == pytest.approx(0.9)  # the model's kind wins
    sent = requests[-1]
    assert sent["constraint"] == "keep the top level" and sent["part"] == "top" and sent["kind"] == "point"
    assert sent["depth"]["unit"] == "mm" and sent["width"] == view.rgb.shape[1]
    whole = seg.segment(view, ElementSpec("red", "red_block"))
    np.testing.assert_array_equal(whole.part_mask, whole.instance_mask)


def test_http_segmenter_not_visible_and_unknown(server, view):
    url, _ = server
    seg = make_segmenter(SegmenterConfig.from_name("http", url=f"{url}/segment"))
    assert seg.segment(view, ElementSpec("g", "green_block")).empty
    with pytest.raises(PerceptionError, match=r"404.*teapot"):
        seg.segment(view, ElementSpec("t", "teapot"))


def test_http_segmenter_server_error_is_one_line(server, view):
    url, _ = server
    seg = make_segmenter(SegmenterConfig.from_name("http", url=f"{url}/boom"))
    with pytest.raises(PerceptionError) as info:
        seg.segment(view, ElementSpec("r", "red_block"))
    msg = str(info.value)
    assert "500" in msg and "model crashed" in msg and "\n" not in msg


def test_http_segmenter_timeout(server, view):
    url, _ = server
    seg = make_segmenter(SegmenterConfig.from_name("http", url=f"{url}/slow", timeout_s=0.2))
    t0 = time.perf_counter()
    with pytest.raises(PerceptionError, match=r"did not answer within 0\.2 s"):
        seg.segment(view, ElementSpec("r", "red_block"))
    assert time.perf_counter() - t0 < 0.9


def test_http_segmenter_unreachable_and_config(view):
    import socket

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()  # nothing listens there now
    seg = make_segmenter(SegmenterConfig.from_name("http", url=f"http://127.0.0.1:{port}/segment", timeout_s=2))
    with pytest.raises(PerceptionError, match="cannot reach"):
        seg.segment(view, ElementSpec("r", "red_block"))
    with pytest.raises(ConfigError, match="url"):
        SegmenterConfig.from_name("http", url="ftp://x")
