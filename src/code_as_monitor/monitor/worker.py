"""The sandbox worker: a separate Python process that runs validated monitor programs.

Started by :class:`~code_as_monitor.monitor.sandbox.Sandbox` as a fresh interpreter
(``python -I -c ... <fd>``) with a minimal environment; it talks over one end of a socket pair with
pickled tuples (protocol 5). This is the only place a monitor program is compiled and executed.

Protocol (requests -> replies):
    worker start                         -> ("ready", pid)
    ("load", source, constraints, cov)   -> ("loaded", n_branches) | ("load_error", message)
    ("eval", seq, E layout, H layout, float64 bytes, t)
                                         -> ("result", seq, [(ok, reason, margin, fault), ...], marks)
    ("exit",)                            -> (process exits)

Containment: resource limits (address space, CPU seconds, open files, processes), a restricted
``__builtins__``, read-only inputs, a low recursion limit, and every check wrapped so that an exception
or a malformed result becomes a fault for that check only.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import resource
import signal
import sys
import types
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from code_as_monitor.geometry.helpers import MONITOR_HELPERS
from code_as_monitor.monitor.allowlist import SAFE_BUILTINS
from code_as_monitor.monitor.instrument import MARKER, instrument
from code_as_monitor.monitor.validate import validate_program

REASON_MAX = 500
RECURSION_LIMIT = 400


class History:
    """``H`` in a monitor program: ``H[i]`` is element i's history (T, k, 3); ``H.t`` is (T,) seconds."""

    __slots__ = ("_d", "t")

    def __init__(self, d: dict[int, np.ndarray], t: np.ndarray) -> None:
        self._d = d
        self.t = t

    def __getitem__(self, i: int) -> np.ndarray:
        return self._d[i]

    def __contains__(self, i: object) -> bool:
        return i in self._d

    def __len__(self) -> int:
        return len(self._d)

    def __iter__(self):
        return iter(self._d)


def _noop_print(*args: Any, **kwargs: Any) -> None:
    """``print`` inside a program does nothing (the worker has no console to spare)."""


def safe_builtins() -> dict[str, Any]:
    """The tiny builtins table a program sees (its ``__builtins__``): :data:`.allowlist.SAFE_BUILTINS`."""
    import builtins

    table = {n: getattr(builtins, n) for n in SAFE_BUILTINS if n not in ("print", "True", "False", "None")}
    table["print"] = _noop_print
    return table


def _type_name(x: object) -> str:
    return type(x).__name__


def normalise(result: object) -> tuple[bool, str, float, bool]:
    """Turn whatever a check returned into ``(ok, reason, margin, fault)``; malformed -> fault."""
    if not isinstance(result, tuple) or len(result) not in (2, 3):
        n = f" of length {len(result)}" if isinstance(result, tuple) else ""
        return False, f"fault: check returned {_type_name(result)}{n}, expected (ok, reason) or (ok, reason, margin)", \
            math.nan, True
    ok, reason = result[0], result[1]
    if type(ok) is not bool and not isinstance(ok, np.bool_):
        return False, f"fault: ok must be a bool, got {_type_name(ok)}", math.nan, True
    if not isinstance(reason, str):
        return False, f"fault: reason must be a str, got {_type_name(reason)}", math.nan, True
    margin = math.nan
    if len(result) == 3:
        m = result[2]
        if isinstance(m, bool | np.bool_) or not isinstance(m, int | float | np.integer | np.floating):
            return False, f"fault: margin must be a float, got {_type_name(m)}", math.nan, True
        margin = float(m)
        if math.isnan(margin):
            return False, "fault: margin is NaN", math.nan, True
    return bool(ok), str.__str__(reason)[:REASON_MAX], margin, False


def _fault_from(exc: BaseException) -> tuple[bool, str, float, bool]:
    try:
        msg = str(exc)[:200]
    except BaseException:
        msg = "?"
    return False, f"fault: raised {_type_name(exc)}: {msg}"[:REASON_MAX], math.nan, True


class _Program:
    """A loaded program: its check functions in constraint order, and the coverage marks."""

    def __init__(self, source: str, constraints: list, coverage: bool) -> None:
        tree = validate_program(source, constraints)
        self.marks: set[int] = set()
        n_branches = 0
        ns: dict[str, Any] = {"__builtins__": safe_builtins(), "np": np, "math": math, **MONITOR_HELPERS}
        if coverage:
            tree, branches = instrument(tree)
            n_branches = len(branches)
            marks = self.marks

            def mark(k: int, value: Any = None) -> Any:
                marks.add(k)
                return value

            ns[MARKER] = mark
        code = compile(tree, "<monitor>", "exec")
        exec(code, ns)  # the one exec of generated code: validated, in this worker only
        self.checks = [ns[c.function_name] for c in constraints]
        self.n_branches = n_branches
        self.coverage = coverage


def unpack(layout_e: tuple, layout_h: tuple, data: bytes) -> tuple[dict, dict, np.ndarray]:
    """Rebuild E, H and H.t as read-only views of one float64 buffer (see ``sandbox.pack``)."""
    flat = np.frombuffer(data, dtype=np.float64)  # bytes are immutable: every view is read-only
    E: dict[int, np.ndarray] = {}
    o = 0
    for i, k in layout_e:
        E[i] = flat[o:o + 3 * k].reshape(k, 3)
        o += 3 * k
    Hd: dict[int, np.ndarray] = {}
    T = 0
    for i, T, k in layout_h:
        Hd[i] = flat[o:o + 3 * T * k].reshape(T, k, 3)
        o += 3 * T * k
    return E, Hd, flat[o:o + T]


def _evaluate(prog: _Program, E: dict, Hd: dict, Ht: np.ndarray, t: float) -> list[tuple]:
    Em = types.MappingProxyType(E)
    H = History(Hd, Ht)
    out = []
    for fn in prog.checks:
        try:
            out.append(normalise(fn(Em, H, t)))
        except BaseException as exc:  # a check may raise anything; it is a fault
            out.append(_fault_from(exc))
    return out


def _set_limits(memory_mb: int, cpu_s: int) -> None:
    with open("/proc/self/status") as f:
        vm = next((int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:")), 0)
    limit = vm + memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 5))
    for lim, value in ((resource.RLIMIT_NPROC, 0), (resource.RLIMIT_CORE, 0)):
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(lim, (value, value))


def _die_with_parent() -> None:
    try:
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def main(fd: int, memory_mb: int, cpu_s: int) -> None:
    """Worker entry point: serve requests on socket ``fd`` until EOF or ``("exit",)``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the control process's business
    _die_with_parent()
    conn = Connection(fd)
    _set_limits(memory_mb, cpu_s)
    sys.setrecursionlimit(RECURSION_LIMIT)
    dumps, loads = pickle.dumps, pickle.loads
    send, recv = conn.send_bytes, conn.recv_bytes
    send(dumps(("ready", os.getpid()), protocol=5))
    prog: _Program | None = None
    while True:
        try:
            msg = loads(recv())
        except (EOFError, OSError):
            return
        kind = msg[0]
        if kind == "eval":
            _, seq, layout_e, layout_h, data, t = msg
            if prog is None:
                send(dumps(("result", seq, None, None), protocol=5))
                continue
            E, Hd, Ht = unpack(layout_e, layout_h, data)
            results = _evaluate(prog, E, Hd, Ht, t)
            marks = sorted(prog.marks) if prog.coverage else None
            prog.marks.clear()
            send(dumps(("result", seq, results, marks), protocol=5))
        elif kind == "load":
            _, source, constraints, coverage = msg
            try:
                prog = _Program(source, constraints, coverage)
                send(dumps(("loaded", prog.n_branches), protocol=5))
            except BaseException as exc:
                prog = None
                send(dumps(("load_error", f"{_type_name(exc)}: {str(exc)[:2000]}"), protocol=5))
        elif kind == "exit":
            return


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]))
