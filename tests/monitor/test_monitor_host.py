"""The control process trusts nothing a worker sends: a worker gone bad at the protocol level (see
``evil_worker.py``) costs a fault verdict for the frame, never an exception, a wait past the deadline
(generous slack), memory growth or a forged verdict. Also: the reply records' own decoders."""

from __future__ import annotations

import math
import os
import signal
import time

import pytest
from evil_worker import BOOT
from hostile_programs import GOOD
from hostutil import RSS_GROWTH_LIMIT, SLACK_S, rss_bytes

from code_as_monitor.core.errors import SandboxError
from code_as_monitor.monitor import process, protocol
from code_as_monitor.monitor.protocol import ReplyError
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.worker import STDERR_LIMIT

MODES = [
    ("announce_huge", "malformed reply"), ("huge_frame", "malformed reply"), ("negative_length", "malformed reply"),
    ("partial_then_stall", "deadline"), ("stall", "deadline"), ("slow_drip", "deadline"),
    ("garbage", "malformed reply"), ("pickle", "malformed reply"), ("wrong_seq", "malformed reply"),
    ("wrong_count", "malformed reply"), ("bad_flags", "malformed reply"), ("long_reason_field", "malformed reply"),
    ("trailing_bytes", "malformed reply"), ("marks_out_of_range", "malformed reply"),
    ("close_socket", "died"), ("exit_code", "died"), ("segfault", "died"),
]
"""Modes after which every check of the frame is a fault, with a word of the reason."""


@pytest.fixture(scope="module")
def evil_box():
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(process, "_BOOT", BOOT)
        mp.setattr(process, "SPAWN", "exec")  # a replaced boot line needs its own interpreter
        with Sandbox(deadline_s=0.2) as sb:
            yield sb


def _load(box: Sandbox, mode: str, constraints) -> None:
    box.load(f"# EVIL: {mode}\n" + GOOD, constraints)


def _timed(box: Sandbox, scene):
    rss0 = rss_bytes()
    t0 = time.perf_counter()
    verdicts = box.evaluate(scene, None, None, 1.0)
    assert time.perf_counter() - t0 < box.deadline_s + SLACK_S  # no wait past the deadline
    assert rss_bytes() - rss0 < RSS_GROWTH_LIMIT  # nothing the worker sent was kept
    return verdicts


def test_an_honest_evil_worker_is_a_worker(evil_box, constraints, scene):
    _load(evil_box, "none", constraints)
    assert [v.ok for v in _timed(evil_box, scene)] == [True, True]


@pytest.mark.parametrize(("mode", "needle"), MODES, ids=[m for m, _ in MODES])
def test_bad_reply_is_a_fault_for_the_frame(mode, needle, evil_box, constraints, scene):
    _load(evil_box, mode, constraints)
    w = evil_box._active
    verdicts = _timed(evil_box, scene)
    assert all(v.fault and not v.ok and math.isnan(v.margin) for v in verdicts), verdicts
    assert needle in verdicts[0].reason, verdicts[0].reason
    assert evil_box.worker_pid != w.pid  # killed and replaced
    if mode in ("segfault", "exit_code"):  # the reason names them when the exit status came in time
        assert w.proc.wait(timeout=10) == {"segfault": -signal.SIGSEGV, "exit_code": 3}[mode]


@pytest.mark.parametrize("mode", ["nan_margin", "inf_margin"])
def test_non_finite_margin_on_the_wire_is_a_fault(mode, evil_box, constraints, scene):
    _load(evil_box, mode, constraints)
    for v in _timed(evil_box, scene):
        assert v.fault and not v.ok and "margin is not finite" in v.reason and math.isnan(v.margin)


def test_escapes_and_addresses_are_cleaned(evil_box, constraints, scene):
    _load(evil_box, "escapes_and_address", constraints)
    for v in _timed(evil_box, scene):
        assert v.ok and not v.fault
        assert "\x1b" not in v.reason and "\r" not in v.reason and "\n" not in v.reason
        assert "0x7fdeadbeef12" not in v.reason and "0x?" in v.reason and "owned" in v.reason


def test_invalid_utf8_is_replaced(evil_box, constraints, scene):
    _load(evil_box, "invalid_utf8", constraints)
    (a, _) = _timed(evil_box, scene)
    assert a.ok and "\ufffd" in a.reason and "bad" in a.reason


def test_a_second_unasked_reply_is_never_taken_for_the_next_frame(evil_box, constraints, scene):
    _load(evil_box, "two_replies", constraints)
    assert [v.ok for v in _timed(evil_box, scene)] == [True, True]
    verdicts = _timed(evil_box, scene)  # the stale copy names the previous request
    assert all(v.fault and "malformed reply" in v.reason for v in verdicts), verdicts


def test_stderr_is_captured_and_bounded(evil_box, constraints, scene):
    _load(evil_box, "stderr_flood", constraints)
    assert [v.ok for v in _timed(evil_box, scene)] == [True, True]
    w = evil_box._active
    assert os.fstat(w.stderr.fileno()).st_size <= STDERR_LIMIT
    tail = w.stderr_tail()
    assert tail.endswith("E") and len(tail) <= 300


def test_a_worker_that_lies_about_its_pid_is_not_started(constraints):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(protocol, "decode_ready", lambda data: (1, 15, 0.0, 0.0, "lie"))
        with pytest.raises(SandboxError, match="failed to start 3 times"):
            Sandbox(start_timeout_s=30).start().close()


def test_an_unconfined_worker_is_refused_unless_opted_out(constraints, scene):
    with pytest.MonkeyPatch.context() as mp:
        real = protocol.decode_ready
        mp.setattr(protocol, "decode_ready", lambda data: (*real(data)[:1], 0, *real(data)[2:4], "pretend"))
        sb = Sandbox()
        with pytest.raises(SandboxError, match=r"could not be confined.*pretend.*allow_unconfined=True"):
            sb.load(GOOD, constraints)
        sb.close()
        with Sandbox(allow_unconfined=True, deadline_s=5.0) as sb:  # generous: a loaded machine
            sb.load(GOOD, constraints)
            assert [v.ok for v in sb.evaluate(scene, None, None, 0.0)] == [True, True]


# --- the record decoders on their own ----------------------------------------------------------------
def _good(seq: int = 7) -> bytes:
    return protocol.encode_result(seq, [(True, "fine", 0.5, False, True), (False, "bad", math.nan, False, False)], [])


def test_decode_result_accepts_exactly_the_layout():
    cache = [(b"", "")] * 2
    out, marks = protocol.decode_result(_good(), 7, 2, 0, cache)
    assert out == [(True, "fine", 0.5, False), (False, "bad", out[1][2], False)] and math.isnan(out[1][2])
    assert marks == []
    for bad in (_good()[:-1], _good() + b"\0", b"X" + _good()[1:], _good()[:5], b""):
        with pytest.raises(ReplyError):
            protocol.decode_result(bad, 7, 2, 0, cache)
    with pytest.raises(ReplyError):
        protocol.decode_result(_good(8), 7, 2, 0, cache)
    with pytest.raises(ReplyError):
        protocol.decode_result(_good(), 7, 3, 0, cache)


def test_clean_text():
    assert protocol.clean_text("a\x1b[31mb\nc") == "a [31mb c"
    assert protocol.clean_text("<f at 0x7ffe12345678>") == "<f at 0x?>"
    assert protocol.clean_text("0x10 stays") == "0x10 stays"
    assert protocol.clean_text("one\u2028two\u2029three\u202efour\u200b\ufefffive\u2066six") == \
        "one two three four five six"
    assert protocol.clean_text("caf\u00e9 \U0001F916 \u00b0") == "caf\u00e9 \U0001F916 \u00b0"  # text stays
    long = protocol.clean_text("z" * 1000)
    assert len(long) == protocol.REASON_MAX and long.endswith("...")


def test_reply_buffer_is_fixed_by_the_program(evil_box, constraints, scene):
    _load(evil_box, "huge_frame", constraints)
    w = evil_box._active
    bound = 4 + max(8192, protocol.max_result_bytes(len(constraints), 0))
    assert len(w._buf) <= bound
    _timed(evil_box, scene)
    assert len(w._buf) <= bound  # the 50 MB frame was refused on its header, never buffered
