"""A sandbox worker gone bad at the protocol level, for testing the control process ("the host").

It is the real worker (imports, confinement, program loading) with its reply sender replaced, so that its
first result reply (and, for some modes, every one) is what a program that had taken over the worker
could send: oversized, truncated, late, forged, garbled, or nothing at all. The mode is named in the
loaded program's source (``# EVIL: <mode>``). Started through :data:`BOOT` in place of the worker's boot
line.
"""

from __future__ import annotations

import ctypes
import os
import re
import struct
import sys
import time
from multiprocessing.connection import Connection

from code_as_monitor.monitor import protocol

HERE = os.path.dirname(os.path.abspath(__file__))
BOOT = ("import time; t0 = time.perf_counter(); import sys; sys.path.insert(0, sys.argv[1]); "
        f"sys.path.insert(0, {HERE!r}); import evil_worker; evil_worker.run(t0)")

_real_send = Connection.send_bytes


def _frame(payload: bytes) -> bytes:
    return struct.pack("!i", len(payload)) + payload


def _raw(conn: Connection, data: bytes) -> None:
    os.write(conn.fileno(), data)


def _result(seq: int, flags: int, margin: float, reason: bytes, n: int = 2, marks: list[int] | None = None) -> bytes:
    body = b"V" + struct.pack("<QH", seq, n)
    for _ in range(n):
        body += struct.pack("<BdH", flags, margin, len(reason)) + reason
    marks = marks or []
    return body + struct.pack("<I", len(marks)) + struct.pack(f"<{len(marks)}I", *marks)


def _misbehave(mode: str, conn: Connection, payload: bytes) -> None:
    seq = struct.unpack_from("<Q", payload, 1)[0]
    if mode == "announce_huge":
        _raw(conn, struct.pack("!i", 300_000_000))
        time.sleep(30)
    elif mode == "huge_frame":  # the header first, then 50 MB of body
        _raw(conn, struct.pack("!i", 50_000_001) + b"V")
        _raw(conn, b"x" * 50_000_000)
    elif mode == "negative_length":
        _raw(conn, struct.pack("!i", -1) + struct.pack("!Q", 10**12))
    elif mode == "partial_then_stall":
        _raw(conn, _frame(payload)[:12])
        time.sleep(30)
    elif mode == "stall":
        time.sleep(30)
    elif mode == "slow_drip":
        for b in _frame(payload):
            _raw(conn, bytes([b]))
            time.sleep(0.02)
    elif mode == "garbage":
        _raw(conn, _frame(bytes(range(7, 250, 3))))
    elif mode == "pickle":
        import pickle

        _raw(conn, _frame(pickle.dumps(("result", seq, [(True, "x", 1.0, False)] * 2, None))))
    elif mode == "wrong_seq":
        _raw(conn, _frame(payload[:1] + struct.pack("<Q", seq + 1) + payload[9:]))
    elif mode == "wrong_count":
        _raw(conn, _frame(_result(seq, 1, 1.0, b"ok", n=1)))
    elif mode == "bad_flags":
        _raw(conn, _frame(_result(seq, 0xFF, 1.0, b"ok")))
    elif mode == "nan_margin":
        _raw(conn, _frame(_result(seq, 1 | 4, float("nan"), b"pass with nan")))
    elif mode == "inf_margin":
        _raw(conn, _frame(_result(seq, 1 | 4, float("inf"), b"pass with inf")))
    elif mode == "long_reason_field":
        _raw(conn, _frame(_result(seq, 1, 1.0, b"y" * 60_000)))
    elif mode == "escapes_and_address":
        _raw(conn, _frame(_result(seq, 1, 1.0, b"\x1b[2J\x1b[31mowned <function f at 0x7fdeadbeef12>\r\n")))
    elif mode == "invalid_utf8":
        _raw(conn, _frame(_result(seq, 1, 1.0, b"\xff\xfe bad \xc3")))
    elif mode == "trailing_bytes":
        _raw(conn, _frame(payload + b"\0\0\0\0"))
    elif mode == "two_replies":
        _raw(conn, _frame(payload) + _frame(payload))
    elif mode == "marks_out_of_range":
        _raw(conn, _frame(_result(seq, 1, 1.0, b"ok", marks=[10**6])))
    elif mode == "close_socket":
        os.close(conn.fileno())
        time.sleep(30)
    elif mode == "exit_code":
        os._exit(3)
    elif mode == "segfault":
        ctypes.string_at(0)
    elif mode == "stderr_flood":
        chunk = b"E" * 65536
        for _ in range(160):  # 10 MiB, far past the worker's RLIMIT_FSIZE
            try:
                os.write(2, chunk)
            except OSError:
                break
        _real_send(conn, payload)
    else:
        raise ValueError(mode)


def run(t0: float) -> None:
    from code_as_monitor.monitor import worker

    mode = ["none"]

    class EvilProgram(worker._Program):
        def __init__(self, source: str, constraints: list, coverage: bool) -> None:
            super().__init__(source, constraints, coverage)
            found = re.search(r"# EVIL: (\w+)", source)
            mode[0] = found.group(1) if found else "none"

    def send_bytes(self: Connection, buf: bytes, offset: int = 0, size: int | None = None) -> None:
        data = bytes(buf)
        if data[:1] != b"V" or mode[0] == "none":  # ready and loaded go through
            _real_send(self, data)
        else:
            _misbehave(mode[0], self, data)

    Connection.send_bytes = send_bytes
    worker._Program = EvilProgram
    worker.main(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), t0)


assert protocol.OK == 1 and protocol.HAS_MARGIN == 4  # the flag bits used above
