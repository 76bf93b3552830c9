"""The worker's replies on the wire: compact binary records the control process parses without trust.

Every message (both ways) is framed as ``multiprocessing.connection`` frames it: a 4-byte big-endian
signed length, then the payload. Requests (control process -> worker) are pickled tuples: the worker
trusts its parent. Replies (worker -> control process) are fixed-layout records built with
:mod:`struct`, never pickles, so the control process decodes them without running anything the worker
chose. Each decoder checks the whole record against its layout (tag, counts, lengths, flag bits, no
trailing bytes) and raises :class:`ReplyError` otherwise.

Reply layouts (little-endian):
    ready:      b"R" pid:u32 flags:u8 boot_ms:f64 confine_ms:f64 notes_len:u16 notes:utf-8
    loaded:     b"L" n_branches:u32
    load_error: b"E" len:u16 message:utf-8
    result:     b"V" seq:u64 n:u16 n x (flags:u8 margin:f64 len:u16 reason:utf-8) n_marks:u32 n_marks x u32

Result flags: bit 0 ok, bit 1 fault, bit 2 a margin was returned. Ready flags: bit 0 seccomp, bit 1
no_new_privs, bit 2 user namespace, bit 3 network namespace.
"""

from __future__ import annotations

import math
import re
import struct

REASON_MAX = 300
"""Characters of a reason kept (the worker truncates, the control process truncates again)."""
REASON_BYTES = 4 * REASON_MAX
NOTES_MAX = 2000
"""Characters of a load error or a confinement note kept."""

_ADDRESS = re.compile(r"0x[0-9a-fA-F]{5,}")
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u200b-\u200f\u2028-\u202e\u2060-\u2069\ufeff]+")
"""C0/C1 controls, Unicode line and paragraph separators, zero-width and bidirectional-override characters:
what could break a log line or make it read differently from what it holds."""

_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_READY = struct.Struct("<IBddH")
_RESULT_HEAD = struct.Struct("<QH")
_CHECK = struct.Struct("<BdH")

OK, FAULT, HAS_MARGIN = 1, 2, 4
SECCOMP, NO_NEW_PRIVS, USER_NS, NET_NS = 1, 2, 4, 8


class ReplyError(ValueError):
    """A worker reply does not match its layout (the worker is then replaced)."""


def clean_text(text: str, limit: int = REASON_MAX) -> str:
    """What the control process keeps of a worker's text: no control, line-separator, zero-width or bidi
    characters (each run becomes a space), no object addresses
    (``0x7f...`` becomes ``0x?``), at most ``limit`` characters."""
    text = _CONTROL.sub(" ", text)
    text = _ADDRESS.sub("0x?", text)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def max_result_bytes(n_checks: int, n_branches: int) -> int:
    """The largest well-formed result payload for a program with these counts."""
    return 1 + _RESULT_HEAD.size + n_checks * (_CHECK.size + REASON_BYTES) + 4 + 4 * n_branches


# --- worker side (encoding) -----------------------------------------------------------------------
def _text(s: str, limit: int) -> bytes:
    b = s[:limit].encode("utf-8", "replace")
    return _U16.pack(len(b)) + b


def encode_ready(pid: int, flags: int, boot_ms: float, confine_ms: float, notes: str) -> bytes:
    b = notes[:NOTES_MAX].encode("utf-8", "replace")
    return b"R" + _READY.pack(pid, flags, boot_ms, confine_ms, len(b)) + b


def encode_loaded(n_branches: int) -> bytes:
    return b"L" + _U32.pack(n_branches)


def encode_load_error(message: str) -> bytes:
    return b"E" + _text(message, NOTES_MAX)


def encode_result(seq: int, results: list[tuple[bool, str, float, bool, bool]], marks: list[int]) -> bytes:
    """``results``: (ok, reason, margin, fault, has_margin) per check, in constraint order."""
    parts = [b"V", _RESULT_HEAD.pack(seq, len(results))]
    for ok, reason, margin, fault, has_margin in results:
        b = reason[:REASON_MAX].encode("utf-8", "replace")
        flags = (OK if ok else 0) | (FAULT if fault else 0) | (HAS_MARGIN if has_margin else 0)
        parts.append(_CHECK.pack(flags, margin, len(b)))
        parts.append(b)
    parts.append(_U32.pack(len(marks)))
    if marks:
        parts.append(struct.pack(f"<{len(marks)}I", *marks))
    return b"".join(parts)


# --- control-process side (strict decoding) ------------------------------------------------------
def _need(data: bytes, end: int) -> None:
    if end > len(data):
        raise ReplyError(f"reply truncated ({len(data)} bytes, needs {end})")


def _decode_text(data: bytes, off: int, n: int, limit: int) -> str:
    _need(data, off + n)
    return clean_text(data[off:off + n].decode("utf-8", "replace"), limit)


def decode_ready(data: bytes) -> tuple[int, int, float, float, str]:
    """-> (pid, confinement flags, boot ms, confinement ms, notes)."""
    if data[:1] != b"R":
        raise ReplyError(f"expected a ready record, got tag {data[:1]!r}")
    _need(data, 1 + _READY.size)
    pid, flags, boot_ms, confine_ms, n = _READY.unpack_from(data, 1)
    off = 1 + _READY.size
    if len(data) != off + n or flags > 15:
        raise ReplyError("malformed ready record")
    return pid, flags, boot_ms, confine_ms, _decode_text(data, off, n, NOTES_MAX)


def decode_load(data: bytes) -> tuple[bool, int | str]:
    """-> (True, n_branches) for "loaded", (False, message) for "load_error"."""
    tag = data[:1]
    if tag == b"L" and len(data) == 5:
        return True, _U32.unpack_from(data, 1)[0]
    if tag == b"E" and len(data) >= 3:
        (n,) = _U16.unpack_from(data, 1)
        if len(data) == 3 + n:
            return False, _decode_text(data, 3, n, NOTES_MAX)
    raise ReplyError(f"expected a load reply, got {len(data)} bytes with tag {tag!r}")


def decode_result(data: bytes, seq: int, n_checks: int, n_branches: int,
                  cache: list[tuple[bytes, str]]) -> tuple[list[tuple[bool, str, float, bool]], list[int]]:
    """Parse a result record: exactly ``n_checks`` results for request ``seq``, marks below ``n_branches``.

    ``cache`` (one ``(raw, clean)`` pair per check, updated here) saves re-cleaning an unchanged reason.
    Returns ``[(ok, reason, margin, fault), ...]`` and the marks. A fault has ``ok`` False; a margin that
    was returned but is not finite turns the result into a fault; no margin is NaN.
    """
    if data[:1] != b"V":
        raise ReplyError(f"expected a result record, got tag {data[:1]!r}")
    _need(data, 1 + _RESULT_HEAD.size)
    got_seq, n = _RESULT_HEAD.unpack_from(data, 1)
    if got_seq != seq or n != n_checks:
        raise ReplyError(f"result for request {got_seq} with {n} checks, expected {seq} with {n_checks}")
    off = 1 + _RESULT_HEAD.size
    out = []
    for k in range(n):
        _need(data, off + _CHECK.size)
        flags, margin, m = _CHECK.unpack_from(data, off)
        off += _CHECK.size
        if flags > 7 or m > REASON_BYTES:
            raise ReplyError(f"malformed result {k}")
        _need(data, off + m)
        raw = data[off:off + m]
        off += m
        prev = cache[k]
        if prev[0] == raw:
            reason = prev[1]
        else:
            reason = clean_text(raw.decode("utf-8", "replace"))
            cache[k] = (raw, reason)
        fault = bool(flags & FAULT)
        if not flags & HAS_MARGIN:
            margin = math.nan
        elif not fault and not math.isfinite(margin):
            out.append((False, clean_text(f"fault: margin is not finite ({margin}); {reason}"), math.nan, True))
            continue
        out.append((bool(flags & OK) and not fault, reason, margin, fault))
    _need(data, off + 4)
    (n_marks,) = _U32.unpack_from(data, off)
    off += 4
    if n_marks > n_branches or len(data) != off + 4 * n_marks:
        raise ReplyError(f"malformed coverage marks ({n_marks} for {n_branches} branches)")
    marks = list(struct.unpack_from(f"<{n_marks}I", data, off)) if n_marks else []
    if marks and max(marks) >= n_branches:
        raise ReplyError("coverage mark out of range")
    return out, marks
