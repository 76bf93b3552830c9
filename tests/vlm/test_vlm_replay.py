"""``replay``: a recorded session is reproduced byte for byte; a miss names the request."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core import Element
from code_as_monitor.core.errors import ConfigError, ReplayMissError, VLMError
from code_as_monitor.planning import ConstraintGenerator, MonitorCoder, basic_check, legend_specs
from code_as_monitor.vlm.backend import KBBackendConfig, ReplayBackendConfig, make_backend
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.replay import ReplayBackend, request_hash

STACK = "stack the blocks: red at the bottom, then green, then blue"
OBJECTS = ["red_block", "green_block", "blue_block", "table"]


def session(backend) -> list[str]:
    """A full stacking plan with a program per subgoal; returns every answer text in order."""
    gen = ConstraintGenerator(backend)
    coder = MonitorCoder(backend, usage=gen.usage)
    rng = np.random.default_rng(0)
    img = {"front": rng.integers(0, 255, (6, 8, 3), dtype=np.uint8)}
    out, prev = [], None
    for _ in range(6):
        sg = gen.next_subgoal(STACK, img, OBJECTS, prev, "success" if prev else None)
        out.append(gen.last_response.text)
        if sg.done:
            break
        els = [Element(i, s.name, s.kind, np.full((1, 3), 0.1 * i), (s.obj, s.part))
               for i, s in enumerate(legend_specs(sg))]
        coder.write_program(sg, els, img, basic_check([c.id for c in sg.constraints]))
        out.append(coder.last_response.text)
        prev = sg
    return out


def test_replay_reproduces_a_recorded_session_byte_for_byte(tmp_path):
    cas = tmp_path / "cassettes" / "stack.jsonl"
    recorded = session(ReplayBackend(cas, mode="record", inner=KBBackend()))
    assert len(recorded) == 9 and len(cas.read_text().splitlines()) == 9
    replayed = session(make_backend(ReplayBackendConfig(cassette=str(cas))))
    assert replayed == recorded
    # recording again gives the same cassette bytes
    cas2 = tmp_path / "again.jsonl"
    session(ReplayBackend(cas2, mode="record", inner=KBBackend()))
    assert cas2.read_bytes() == cas.read_bytes()


def test_replay_miss_names_the_request(tmp_path):
    cas = tmp_path / "c.jsonl"
    ReplayBackend(cas, mode="record", inner=KBBackend())
    be = ReplayBackend(cas)
    msgs = [Message.user("what is this?")]
    with pytest.raises(ReplayMissError) as info:
        be.complete(msgs, purpose="vqa")
    msg = str(info.value)
    assert request_hash(msgs, "vqa")[:16] in msg and "purpose vqa" in msg and "what is this?" in msg


def test_images_change_the_hash():
    a = np.zeros((2, 2, 3), np.uint8)
    b = a.copy()
    b[0, 0, 0] = 1
    h = lambda img: request_hash([Message.user("x", {"v": img})], "p")  # noqa: E731
    assert h(a) == h(a.copy()) != h(b)


def test_repeated_requests_replay_in_order_and_auto_records_misses(tmp_path):
    class Counter:
        def __init__(self):
            self.n = 0

        def complete(self, messages, *, purpose, schema=None):
            from code_as_monitor.vlm.backend import VLMResponse

            self.n += 1
            return VLMResponse(f"answer {self.n}", 1, 1, "counter")

    cas = tmp_path / "c.jsonl"
    rec = ReplayBackend(cas, mode="record", inner=Counter())
    msgs = [Message.user("same")]
    assert [rec.complete(msgs, purpose="p").text for _ in range(2)] == ["answer 1", "answer 2"]
    rep = ReplayBackend(cas)
    assert [rep.complete(msgs, purpose="p").text for _ in range(3)] == ["answer 1", "answer 2", "answer 2"]
    inner = Counter()
    auto = ReplayBackend(cas, mode="auto", inner=inner)
    assert auto.complete(msgs, purpose="p").text == "answer 1" and inner.n == 0
    assert auto.complete([Message.user("new")], purpose="p").text == "answer 1" and inner.n == 1
    assert len(cas.read_text().splitlines()) == 3


def test_replay_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="needs an inner backend"):
        ReplayBackendConfig(cassette="x.jsonl", mode="record")
    with pytest.raises(VLMError, match="does not exist"):
        make_backend(ReplayBackendConfig(cassette=str(tmp_path / "missing.jsonl")))
    bad = tmp_path / "bad.jsonl"
    bad.write_text("not json\n")
    with pytest.raises(VLMError, match="line 1"):
        ReplayBackend(bad)
    rec = make_backend(ReplayBackendConfig(cassette=str(tmp_path / "k.jsonl"), mode="record",
                                           inner=KBBackendConfig()))
    assert isinstance(rec, ReplayBackend) and isinstance(rec.inner, KBBackend)
