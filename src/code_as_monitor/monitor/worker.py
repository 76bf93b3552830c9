"""The sandbox worker: a separate, kernel-confined Python process that runs one monitor program.

Started by :class:`~code_as_monitor.monitor.sandbox.Sandbox` as a fresh interpreter
(``python -I -c ... <fd> ...``) with a minimal environment, stdout on ``/dev/null`` and stderr on a
size-limited file the control process reads. This is the only place a monitor program is compiled and
executed. A worker serves one program: the control process starts a fresh one for every load.

Start-up, in order: imports; a warm-up that runs every allowed numpy function and every kind of
formatting once (numpy imports some of its modules lazily, and nothing can be imported once the filter
is on); resource limits; :func:`~code_as_monitor.monitor.confine.confine`; then the ``ready`` record.

Protocol (requests are pickled tuples; replies are :mod:`.protocol` records):
    worker start                           -> ready
    ("load", source, constraints, cov)     -> loaded | load_error
    ("eval", seq, E layout, H layout, float64 bytes, t)
                                           -> result
    ("exit",)                              -> (process exits)

Inside: a restricted ``__builtins__`` (an ``__import__`` that only hands numpy back its own, already
imported modules), the :mod:`.npsurface` proxies for ``np`` and ``math``, read-only inputs, a low
recursion limit, and every check wrapped so that an exception or a malformed result becomes a fault for
that check only.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import resource
import signal
import sys
import time
import types
import warnings
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from code_as_monitor.geometry.helpers import MONITOR_HELPERS
from code_as_monitor.monitor import protocol
from code_as_monitor.monitor.allowlist import SAFE_BUILTINS
from code_as_monitor.monitor.confine import confine, load_seccomp
from code_as_monitor.monitor.frames import unpack
from code_as_monitor.monitor.instrument import MARKER, instrument
from code_as_monitor.monitor.npsurface import build_math, build_numpy
from code_as_monitor.monitor.validate import validate_program
from code_as_monitor.monitor.warmup import warm_up

RECURSION_LIMIT = 400
STDERR_LIMIT = 64 * 1024
"""Bytes the worker may write to its stderr file (``RLIMIT_FSIZE``)."""
IMPORTABLE = frozenset({"numpy"})
"""Top-level packages whose already-imported modules C code may look up through ``__import__``."""


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


def _import_loaded(name: str, globals: Any = None, locals: Any = None, fromlist: Any = (), level: int = 0) -> Any:
    """``__import__`` for C code called from a program (numpy formats arrays through a lazy import):
    already-imported numpy modules only, never a new import."""
    top = name.partition(".")[0]
    mod = sys.modules.get(name)
    if level != 0 or mod is None or top not in IMPORTABLE:
        raise ImportError(f"import of {name!r} is not available in a monitor program")
    return mod if fromlist else sys.modules[top]


def safe_builtins() -> dict[str, Any]:
    """The tiny builtins table a program sees (its ``__builtins__``): :data:`.allowlist.SAFE_BUILTINS`."""
    import builtins

    table = {n: getattr(builtins, n) for n in SAFE_BUILTINS if n not in ("print", "True", "False", "None")}
    table["print"] = _noop_print
    table["__import__"] = _import_loaded  # no program can name it (dunder names are rejected)
    return table


def _type_name(x: object) -> str:
    return type(x).__name__


Result = tuple[bool, str, float, bool, bool]
"""(ok, reason, margin, fault, has_margin) of one check."""


def _fault(reason: str) -> Result:
    return False, "fault: " + reason, math.nan, True, False


def normalise(result: object) -> Result:
    """Turn whatever a check returned into a :data:`Result`; anything malformed is a fault."""
    if type(result) is tuple and len(result) == 3:  # the common shape, with exact built-in types: no checks left
        ok, reason, m = result
        if type(ok) is bool and type(reason) is str and type(m) is float and math.isfinite(m):
            return ok, reason[:protocol.REASON_MAX], m, False, True
    if not isinstance(result, tuple) or len(result) not in (2, 3):
        n = f" of length {len(result)}" if isinstance(result, tuple) else ""
        return _fault(f"check returned {_type_name(result)}{n}, expected (ok, reason) or (ok, reason, margin)")
    ok, reason = result[0], result[1]
    if type(ok) is not bool and type(ok) is not np.bool_:
        return _fault(f"ok must be a bool, got {_type_name(ok)}")
    if not isinstance(reason, str):
        return _fault(f"reason must be a str, got {_type_name(reason)}")
    if len(result) == 2:
        return bool(ok), str.__str__(reason)[:protocol.REASON_MAX], math.nan, False, False
    m = result[2]
    if isinstance(m, bool | np.bool_) or not isinstance(m, int | float | np.integer | np.floating):
        return _fault(f"margin must be a float, got {_type_name(m)}")
    try:
        margin = float(m)
    except OverflowError:
        margin = math.inf
    if not math.isfinite(margin):
        return _fault(f"margin is not finite ({margin})")
    return bool(ok), str.__str__(reason)[:protocol.REASON_MAX], margin, False, True


def _fault_from(exc: BaseException) -> Result:
    try:
        msg = str(exc)[:200]
    except BaseException:
        msg = "?"
    return _fault(f"raised {_type_name(exc)}: {msg}")


class _Program:
    """A loaded program: its check functions in constraint order, and the coverage marks."""

    def __init__(self, source: str, constraints: list, coverage: bool) -> None:
        tree = validate_program(source, constraints)
        self.marks: set[int] = set()
        n_branches = 0
        ns: dict[str, Any] = {"__builtins__": safe_builtins(), "np": build_numpy(), "math": build_math(),
                              **MONITOR_HELPERS}
        if coverage:
            tree, branches = instrument(tree)
            n_branches = len(branches)
            marks = self.marks

            def mark(k: int, value: Any = None) -> Any:
                marks.add(k)
                return value

            ns[MARKER] = mark
        code = compile(tree, "<monitor>", "exec")
        exec(code, ns)  # the one exec of generated code: validated, in this confined worker only
        self.checks = [ns[c.function_name] for c in constraints]
        self.n_branches = n_branches
        self.coverage = coverage


def _evaluate(prog: _Program, E: dict, Hd: dict, Ht: np.ndarray, t: float) -> list[Result]:
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
    for lim, value in ((resource.RLIMIT_NPROC, 0), (resource.RLIMIT_CORE, 0),
                       (resource.RLIMIT_FSIZE, STDERR_LIMIT)):
        with contextlib.suppress(ValueError, OSError):
            resource.setrlimit(lim, (value, value))


def _flags(info: Any) -> int:
    return ((protocol.SECCOMP if info.seccomp else 0) | (protocol.NO_NEW_PRIVS if info.no_new_privs else 0)
            | (protocol.USER_NS if info.user_ns else 0) | (protocol.NET_NS if info.net_ns else 0))


def main(fd: int, memory_mb: int, cpu_s: int, want_confinement: int, t_boot: float, warmed: bool = False) -> None:
    """Worker entry point: confine, then serve requests on socket ``fd`` until EOF or ``("exit",)``.

    Args:
        fd: the inherited socket to the control process.
        memory_mb: address space allowed beyond the size after start-up, MiB.
        cpu_s: lifetime CPU seconds.
        want_confinement: 1 to install the confinement, 0 to skip it (the caller opted out).
        t_boot: ``time.perf_counter()`` when the interpreter started running the boot line (a forked
            worker: when it was forked).
        warmed: the namespace was already exercised (a worker forked from the fork server, which did it once).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the control process's business
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a full stderr file fails the write, not the worker
    warnings.simplefilter("ignore")
    np.seterr(all="ignore")
    conn = Connection(fd)
    if not warmed:
        warm_up()
    seccomp = load_seccomp() if want_confinement else None  # imports (and finds libseccomp) before the limits
    _set_limits(memory_mb, cpu_s)
    sys.setrecursionlimit(RECURSION_LIMIT)
    loads = pickle.loads
    send, recv = conn.send_bytes, conn.recv_bytes
    encode_result = protocol.encode_result
    t0 = time.perf_counter()
    if want_confinement:
        info = confine(fd, 2, seccomp=seccomp)
        notes = info.describe()
    else:
        info, notes = None, "confinement skipped (the caller opted out)"
    t1 = time.perf_counter()
    flags = _flags(info) if info is not None else 0
    send(protocol.encode_ready(os.getpid(), flags, (t0 - t_boot) * 1e3, (t1 - t0) * 1e3, notes))
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
                return  # the control process never evaluates before a load: it is confused, stop
            E, Hd, Ht = unpack(layout_e, layout_h, data)
            results = _evaluate(prog, E, Hd, Ht, t)
            marks = sorted(prog.marks) if prog.coverage else []
            prog.marks.clear()
            send(encode_result(seq, results, marks))
        elif kind == "load":
            _, source, constraints, coverage = msg
            if prog is not None:
                return  # one program per worker
            try:
                prog = _Program(source, constraints, coverage)
                send(protocol.encode_loaded(prog.n_branches))
            except BaseException as exc:
                prog = None
                try:
                    text = f"{_type_name(exc)}: {str(exc)[:protocol.NOTES_MAX]}"
                except BaseException:
                    text = _type_name(exc)
                send(protocol.encode_load_error(text))
        elif kind == "exit":
            return
