"""Run monitor programs in a persistent, resource-limited worker process with a per-call deadline.

The control process never executes generated code. :class:`Sandbox` starts
:mod:`code_as_monitor.monitor.worker` as a fresh interpreter (``python -I``, minimal environment, no
inherited secrets) connected by a socket pair, sends the program once per subgoal (:meth:`Sandbox.load`)
and then makes exactly one round trip per frame for all checks (:meth:`Sandbox.evaluate`).

When a round trip overruns its deadline the worker is killed, every check of that frame gets a fault
verdict, and a replacement is started *in the background* with the same program: until it is ready,
:meth:`Sandbox.evaluate` answers at once with "restarting" faults. A worker that dies (segfault, CPU
limit) is handled the same way. The control loop never waits past the deadline.
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import os
import pickle
import socket
import subprocess
import sys
import time
import weakref
from multiprocessing.connection import Connection
from pathlib import Path

import numpy as np

import code_as_monitor
from code_as_monitor.core.constraints import Constraint, Verdict
from code_as_monitor.core.errors import ProgramError, SandboxError, ShapeMismatchError
from code_as_monitor.monitor.validate import validate_program

log = logging.getLogger(__name__)

_BOOT = ("import sys; sys.path.insert(0, sys.argv[1]); from code_as_monitor.monitor.worker import main; "
         "main(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]))")
_SRC_ROOT = str(Path(code_as_monitor.__file__).resolve().parent.parent)
_WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "PATH": os.defpath, "LC_ALL": "C.UTF-8"}
MAX_START_FAILURES = 3


class _ReplyUnpickler(pickle.Unpickler):
    """Replies come from a process running untrusted code: allow plain data only, never a global."""

    def find_class(self, module: str, name: str):
        raise pickle.UnpicklingError(f"worker reply refers to {module}.{name}")


def _loads_reply(data: bytes) -> tuple:
    return _ReplyUnpickler(io.BytesIO(data)).load()


def pack(elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
         history_t: np.ndarray | None, t: float) -> tuple[tuple, tuple, bytes]:
    """Flatten a frame into one float64 buffer plus its layout (cheaper than pickling many arrays).

    Returns:
        ``((id, k), ...)`` of the elements, ``((id, T, k), ...)`` of the history, and the bytes of
        ``[E..., H..., H.t]``. ``history=None`` means the current frame alone (T = 1, ``H.t = [t]``).
    Raises:
        ShapeMismatchError: points are not (k, 3), histories not (T, k, 3), or ``history_t`` not (T,).
    """
    E = [(int(i), np.asarray(p, dtype=np.float64)) for i, p in elements.items()]
    for i, p in E:
        if (p.ndim != 2 or p.shape[1] != 3) and p.shape != (3,):
            raise ShapeMismatchError(f"element {i}: points must be (k, 3), got {p.shape}")
    E = [(i, p.reshape(-1, 3)) for i, p in E]
    if history is None:
        Hs = [(i, p[None]) for i, p in E]
        Ht = np.array([t], dtype=np.float64)
    else:
        Hs = [(int(i), np.asarray(h, dtype=np.float64)) for i, h in history.items()]
        Ht = np.asarray(history_t if history_t is not None else [t], dtype=np.float64).reshape(-1)
        for i, h in Hs:
            if h.ndim != 3 or h.shape[2] != 3 or h.shape[0] != Ht.shape[0]:
                raise ShapeMismatchError(f"history of element {i} must be (T={Ht.shape[0]}, k, 3), got {h.shape}")
    parts = [p.ravel() for _, p in E] + [h.ravel() for _, h in Hs] + [Ht]
    data = np.concatenate(parts).tobytes() if parts else b""
    return tuple((i, p.shape[0]) for i, p in E), tuple((i, h.shape[0], h.shape[1]) for i, h in Hs), data


def _reap(proc: subprocess.Popen) -> None:
    with contextlib.suppress(OSError):
        proc.kill()


class Sandbox:
    """A persistent worker process that evaluates one monitor program per subgoal.

    Args:
        deadline_s: wall-clock budget of one :meth:`evaluate` round trip, seconds (default 20 ms).
        memory_mb: address space the worker may allocate beyond its size after start-up, MiB.
        cpu_s: lifetime CPU seconds of one worker (``RLIMIT_CPU``, a backstop; it is then replaced).
        start_timeout_s: how long :meth:`start` and :meth:`load` wait for a fresh worker.
        load_timeout_s: how long :meth:`load` waits for the program's module-level code.

    Use as a context manager, or call :meth:`start` and :meth:`close`.
    """

    def __init__(self, deadline_s: float = 0.020, memory_mb: int = 512, cpu_s: int = 600,
                 start_timeout_s: float = 20.0, load_timeout_s: float = 2.0) -> None:
        if not deadline_s > 0 or memory_mb < 32 or cpu_s < 1:
            raise SandboxError(
                f"bad sandbox limits: deadline_s={deadline_s!r}, memory_mb={memory_mb!r}, cpu_s={cpu_s!r}")
        self.deadline_s = float(deadline_s)
        self.memory_mb = int(memory_mb)
        self.cpu_s = int(cpu_s)
        self.start_timeout_s = float(start_timeout_s)
        self.load_timeout_s = float(load_timeout_s)
        self._proc: subprocess.Popen | None = None
        self._conn: Connection | None = None
        self._ready = False  # the worker said "ready" and acknowledged the current program
        self._awaiting: list[str] = []  # replies still expected before the worker is ready
        self._program: tuple[str, list[Constraint], bool] | None = None
        self._constraints: list[Constraint] = []
        self._seq = 0
        self._start_failures = 0
        self.n_restarts = 0
        self.n_branches = 0
        self.last_marks: list[int] = []
        self._finalizer = weakref.finalize(self, Sandbox._kill_all, [])

    # --- lifecycle --------------------------------------------------------------------------------
    @staticmethod
    def _kill_all(procs: list[subprocess.Popen]) -> None:
        for p in procs:
            _reap(p)

    def _spawn(self) -> None:
        """Start a worker without waiting for it; queue the current program if there is one."""
        parent, child = socket.socketpair()
        try:
            proc = subprocess.Popen(
                [sys.executable, "-I", "-c", _BOOT, _SRC_ROOT, str(child.fileno()), str(self.memory_mb),
                 str(self.cpu_s)],
                pass_fds=(child.fileno(),), env=_WORKER_ENV, stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, close_fds=True,
            )
        except OSError as exc:
            parent.close()
            raise SandboxError(f"cannot start the sandbox worker: {exc}") from exc
        finally:
            child.close()
        self._proc = proc
        self._finalizer.detach()
        self._finalizer = weakref.finalize(self, Sandbox._kill_all, [proc])
        self._conn = Connection(parent.detach())
        self._ready = False
        self._awaiting = ["ready"]
        if self._program is not None:
            self._send(("load", *self._program))
            self._awaiting.append("loaded")

    def start(self) -> Sandbox:
        """Start the worker and wait until it is ready (raises SandboxError after ``start_timeout_s``)."""
        if self._proc is None:
            self._spawn()
        self._wait_ready(self.start_timeout_s)
        return self

    def close(self) -> None:
        """Stop the worker (politely, then by force)."""
        proc, conn = self._proc, self._conn
        self._proc, self._conn, self._ready = None, None, False
        if conn is not None:
            with contextlib.suppress(OSError):
                conn.send_bytes(pickle.dumps(("exit",), protocol=5))
            conn.close()
        if proc is not None:
            try:
                proc.wait(timeout=0.5)
            except subprocess.TimeoutExpired:
                _reap(proc)
                proc.wait()
        self._finalizer.detach()

    def __enter__(self) -> Sandbox:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def worker_pid(self) -> int | None:
        """Process id of the current worker (None when there is none)."""
        return self._proc.pid if self._proc is not None else None

    def _kill_and_replace(self, why: str) -> None:
        log.warning("sandbox worker replaced: %s", why)
        if self._proc is not None:
            _reap(self._proc)
            # SIGKILL is immediate; reap without blocking (a late zombie is collected by Popen later)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self._proc.wait(timeout=0)
        if self._conn is not None:
            self._conn.close()
        self._proc, self._conn, self._ready = None, None, False
        self.n_restarts += 1
        self._spawn()

    # --- messaging --------------------------------------------------------------------------------
    def _send(self, msg: tuple) -> None:
        assert self._conn is not None
        self._conn.send_bytes(pickle.dumps(msg, protocol=5))

    def _recv(self) -> tuple:
        assert self._conn is not None
        return _loads_reply(self._conn.recv_bytes())

    def _progress(self, timeout: float) -> None:
        """Consume start-up/load acknowledgements for at most ``timeout`` seconds."""
        end = time.perf_counter() + timeout
        while self._awaiting and self._conn is not None:
            if not self._conn.poll(max(0.0, end - time.perf_counter())):
                if self._proc is not None and self._proc.poll() is not None:
                    self._start_failed(f"worker exited with code {self._proc.returncode} during start-up")
                return
            try:
                reply = self._recv()
            except (EOFError, OSError):
                self._start_failed("worker closed its connection during start-up")
                return
            if reply[0] == "load_error":
                raise ProgramError(f"monitor program failed to load in the sandbox: {reply[1]}")
            if reply[0] != self._awaiting[0]:
                raise SandboxError(f"unexpected worker reply {reply[0]!r}, expected {self._awaiting[0]!r}")
            if reply[0] == "loaded":
                self.n_branches = int(reply[1])
            self._awaiting.pop(0)
        self._ready = not self._awaiting
        if self._ready:
            self._start_failures = 0

    def _start_failed(self, why: str) -> None:
        self._start_failures += 1
        if self._start_failures >= MAX_START_FAILURES:
            if self._proc is not None:
                _reap(self._proc)
            if self._conn is not None:
                self._conn.close()
            self._proc, self._conn, self._ready = None, None, False
            raise SandboxError(f"sandbox worker failed to start {self._start_failures} times: {why}")
        self._kill_and_replace(why)

    def _wait_ready(self, timeout: float) -> None:
        end = time.perf_counter() + timeout
        while not self._ready:
            if self._proc is None:
                self._spawn()
            left = end - time.perf_counter()
            if left <= 0:
                self._kill_and_replace("start-up timed out")
                raise SandboxError(f"sandbox worker not ready after {timeout:.1f} s")
            self._progress(min(left, 0.05))

    # --- programs ---------------------------------------------------------------------------------
    def load(self, source: str, constraints: list[Constraint], *, coverage: bool = False) -> None:
        """Validate ``source`` here, then compile and run its module level in the worker.

        Args:
            source: monitor program (one ``check_<id>(E, H, t)`` per constraint).
            constraints: the constraints, in the order verdicts are returned.
            coverage: load the branch-instrumented program (used by path coverage); the marks of each
                :meth:`evaluate` call are then in :attr:`last_marks`.
        Raises:
            ProgramError: the program is rejected, fails to compile, or its module level fails/overruns.
        """
        validate_program(source, constraints)
        try:
            self._wait_ready(self.start_timeout_s)
        except ProgramError:  # a replacement could not reload the previous program: drop it
            self._program, self._awaiting, self._ready = None, [], True
        self._program = (source, list(constraints), coverage)
        self._constraints = list(constraints)
        self._send(("load", source, list(constraints), coverage))
        self._awaiting = ["loaded"]
        self._ready = False
        try:
            self._progress(self.load_timeout_s)
        except ProgramError:
            self._program, self._constraints, self._ready, self._awaiting = None, [], True, []
            raise
        if not self._ready:
            self._program, self._constraints = None, []
            self._kill_and_replace("program load timed out")
            raise ProgramError(f"monitor program's module-level code did not finish within {self.load_timeout_s} s")

    # --- evaluation -------------------------------------------------------------------------------
    def _faults(self, reason: str, t: float) -> list[Verdict]:
        return [Verdict(c.id, c.phase, False, f"fault: {reason}", math.nan, t, True) for c in self._constraints]

    def evaluate(self, elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
                 history_t: np.ndarray | None, t: float, *, deadline_s: float | None = None) -> list[Verdict]:
        """Run every check once on this frame: one round trip, bounded by the deadline.

        Args:
            elements: element id -> (k, 3) current points, world metres.
            history: element id -> (T, k, 3), oldest first (None: the current frame only, T = 1).
            history_t: (T,) seconds of the history frames (None with ``history=None``).
            t: current time, seconds.
            deadline_s: override of the sandbox's deadline for this call.
        Returns:
            One :class:`Verdict` per constraint, in constraint order; ``fault=True`` when the program
            failed (exception, malformed result, deadline, worker crash or restart).
        """
        start = time.perf_counter()
        deadline = self.deadline_s if deadline_s is None else float(deadline_s)
        if self._program is None:
            raise SandboxError("Sandbox.evaluate called before load()")
        if not self._ready:
            try:
                self._progress(0.0)
            except ProgramError as exc:  # a replacement that cannot reload the program
                self._kill_and_replace(str(exc))
                return self._faults(f"monitor worker could not be restarted: {exc}", t)
            if not self._ready:
                return self._faults("monitor worker is restarting", t)
        layout_e, layout_h, data = pack(elements, history, history_t, t)
        self._seq += 1
        try:
            self._send(("eval", self._seq, layout_e, layout_h, data, float(t)))
            if not self._conn.poll(max(0.0, deadline - (time.perf_counter() - start))):
                self._kill_and_replace(f"deadline {deadline * 1e3:.0f} ms exceeded")
                return self._faults(f"deadline {deadline * 1e3:.0f} ms exceeded", t)
            reply = self._recv()
        except (EOFError, OSError) as exc:
            code = self._proc.poll() if self._proc is not None else None
            how = f"signal {-code}" if code is not None and code < 0 else f"exit code {code}"
            self._kill_and_replace(f"worker died ({how})")
            return self._faults(f"monitor worker died ({how}; {type(exc).__name__})", t)
        if reply[0] != "result" or reply[1] != self._seq or reply[2] is None:
            self._kill_and_replace(f"bad worker reply {reply[0]!r}")
            return self._faults("monitor worker gave a malformed reply", t)
        self.last_marks = list(reply[3] or ())
        return [Verdict(c.id, c.phase, bool(ok), str(reason), float(margin), t, bool(fault))
                for c, (ok, reason, margin, fault) in zip(self._constraints, reply[2])]
