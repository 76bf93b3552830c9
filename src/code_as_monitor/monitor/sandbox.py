"""Run monitor programs in fresh, kernel-confined worker processes with a per-frame deadline.

The control process never executes generated code. :class:`Sandbox` keeps *spare* workers started
(:mod:`.lifecycle`, :mod:`.pool`, :mod:`.process`, :mod:`.worker`): fresh interpreters that have imported what they need
and confined themselves (:mod:`.confine`: seccomp filter, ``no_new_privs``, new user and network
namespaces where the kernel allows them). Every :meth:`Sandbox.load` hands the program to a spare, so no
state carries from one program to the next, and starts the next spare once the program is loaded; after
a kill, a spawner thread starts it. Then :meth:`Sandbox.evaluate` makes exactly one round trip per frame
for all checks, the frame shipped as one buffer (:mod:`.frames`).

The control process trusts nothing a worker sends: replies are bounded in size and parsed against a
fixed layout (:mod:`.protocol`), reasons are truncated and stripped of addresses, non-finite margins
are faults, and a late, malformed or missing reply makes every check of that frame a fault verdict
(never an exception): the worker is killed and the spare takes over with the same program. Until it has
loaded, :meth:`Sandbox.evaluate` answers at once with "restarting" faults. No call of
:meth:`Sandbox.evaluate` waits past its deadline: it never starts a process itself.

Where confinement cannot be installed the worker says why and generated code does not run, unless the
caller opts out explicitly: ``Sandbox(allow_unconfined=True)`` or ``CAM_ALLOW_UNCONFINED=1``.
"""

from __future__ import annotations

import math
import os
import pickle
import time

import numpy as np

from code_as_monitor.core.checks import DEADLINE_S_RANGE, check_count, check_range
from code_as_monitor.core.constraints import Constraint, Verdict
from code_as_monitor.core.errors import ConfigError, ProgramError, SandboxError
from code_as_monitor.monitor import protocol
from code_as_monitor.monitor.frames import pack
from code_as_monitor.monitor.lifecycle import ALLOW_UNCONFINED_ENV, MAX_START_FAILURES, WorkerLifecycle
from code_as_monitor.monitor.process import LateError, WorkerProcess
from code_as_monitor.monitor.protocol import ReplyError
from code_as_monitor.monitor.validate import validate_program

__all__ = ["ALLOW_UNCONFINED_ENV", "MAX_START_FAILURES", "Sandbox", "pack"]


class Sandbox(WorkerLifecycle):
    """Fresh confined workers, one per loaded program, with a spare always starting in the background.

    Args:
        deadline_s: wall-clock budget of one :meth:`evaluate` round trip, seconds (default 20 ms).
        memory_mb: address space a worker may allocate beyond its size after start-up, MiB.
        cpu_s: lifetime CPU seconds of one worker (``RLIMIT_CPU``, a backstop; it is then replaced).
        start_timeout_s: CPU seconds a starting worker may use before :meth:`start` and :meth:`load` give up on
            its ready record; the wait is wall-clock time, extended while the worker has used less CPU than this
            (a busy machine made it late), up to ``start_wall_s`` after its spawn.
        start_wall_s: wall-clock ceiling of that wait, seconds (default: 10 x ``start_timeout_s``).
        load_timeout_s: CPU seconds the program's module-level code may use in :meth:`load`. The wait is
            wall-clock time, extended while the worker has used less CPU than this (a busy machine, not the
            program, made it late), up to ``load_wall_s``.
        load_wall_s: wall-clock ceiling of the module-level wait, seconds (default: 10 x ``load_timeout_s``).
        spares: workers kept started beyond the one running the program (>= 1).
        confine: install the kernel confinement in every worker (False needs ``allow_unconfined``).
        allow_unconfined: run generated code even where the confinement cannot be installed (an explicit
            opt-out; default: the ``CAM_ALLOW_UNCONFINED`` environment variable is ``1``).

    Use as a context manager, or call :meth:`start` and :meth:`close`.
    """

    def __init__(self, deadline_s: float = 0.020, memory_mb: int = 512, cpu_s: int = 600,
                 start_timeout_s: float = 20.0, load_timeout_s: float = 2.0, spares: int = 1,
                 confine: bool = True, allow_unconfined: bool | None = None,
                 load_wall_s: float | None = None, start_wall_s: float | None = None) -> None:
        try:
            check_range("Sandbox", "deadline_s", deadline_s, *DEADLINE_S_RANGE)
            for f, v, lo in (("memory_mb", memory_mb, 32), ("cpu_s", cpu_s, 1), ("spares", spares, 1)):
                check_count("Sandbox", f, v, lo)
        except ConfigError as exc:
            raise SandboxError(f"bad sandbox limits: {exc}") from None
        if allow_unconfined is None:
            allow_unconfined = os.environ.get(ALLOW_UNCONFINED_ENV, "") == "1"
        if not confine and not allow_unconfined:
            raise SandboxError("confine=False runs generated code without kernel confinement; pass "
                               "allow_unconfined=True as well to opt out explicitly")
        super().__init__(memory_mb, cpu_s, start_timeout_s, spares, confine, allow_unconfined, start_wall_s)
        self.deadline_s = float(deadline_s)
        self.load_timeout_s = float(load_timeout_s)
        self.load_wall_s = max(self.load_timeout_s, 10.0 * self.load_timeout_s if load_wall_s is None else load_wall_s)
        self._constraints: list[Constraint] = []
        self._reasons: list[tuple[bytes, str]] = []
        self._seq = 0
        self.n_branches = 0
        self.last_marks: list[int] = []
        self.last_load_s = math.nan

    def start(self) -> Sandbox:
        """Make sure a spare is ready (and a replacement worker has reloaded the program).

        Raises:
            SandboxError: no worker came up within ``start_timeout_s``, or it could not be confined (and
                the caller did not opt out).
        """
        super().start()
        return self

    def __enter__(self) -> Sandbox:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- programs ---------------------------------------------------------------------------------
    def load(self, source: str, constraints: list[Constraint], *, coverage: bool = False) -> None:
        """Validate ``source`` here, then load it into a fresh worker (the previous one is killed).

        Args:
            source: monitor program (one ``check_<id>(E, H, t)`` per constraint).
            constraints: the constraints, in the order verdicts are returned.
            coverage: load the branch-instrumented program (used by path coverage); the marks of each
                :meth:`evaluate` call are then in :attr:`last_marks`.
        Raises:
            ProgramError: the program is rejected, fails to compile, or its module level fails/overruns.
            SandboxError: no confined worker could be started.
        """
        t0 = time.perf_counter()
        validate_program(source, constraints)
        self._retire(self._active)
        self._active, self._program, self._constraints = None, None, []
        try:  # the next spare starts once this load is done, not competing with it
            w = self._ready_worker(t0 + self.start_timeout_s, refill=False)
            self._load_into(w, source, constraints, coverage)
        finally:
            if self._pool is not None:
                self._pool.refill()
        self.last_load_s = time.perf_counter() - t0

    def _load_into(self, w: WorkerProcess, source: str, constraints: list[Constraint], coverage: bool) -> None:
        self._max_reply = protocol.max_result_bytes(len(constraints), 10_000 if coverage else 0)
        w.allow_reply(self._max_reply)
        try:
            w.send(pickle.dumps(("load", source, list(constraints), coverage), protocol=5),
                   time.perf_counter() + self.load_timeout_s)
            w.awaiting.append("loaded")
            self._absorb_load(w)
        except ProgramError:
            self._retire(w)
            raise
        except LateError:
            self._retire(w)
            raise ProgramError(f"monitor program's module-level code did not finish within "
                               f"{self.load_timeout_s} s of CPU time ({self.load_wall_s} s wall at most)") from None
        except (EOFError, OSError, ReplyError) as exc:
            why = f"{type(exc).__name__}: {exc}; {w.how_it_ended()}"
            self._retire(w)
            raise ProgramError(f"monitor program failed to load in the sandbox: the worker {why}") from None
        self._active = w
        self._program = (source, list(constraints), coverage)
        self._constraints = list(constraints)
        self._reasons = [(b"\0", "")] * len(constraints)
        self.n_branches = w.n_branches

    def _absorb_load(self, w: WorkerProcess) -> None:
        """Wait for the load reply: ``load_timeout_s`` of the worker's CPU time, within ``load_wall_s`` of
        wall time (raises :class:`LateError` past either; where CPU time cannot be read, the wall budget is
        ``load_timeout_s``)."""
        start = time.perf_counter()
        self._absorb_cpu(w, start + self.load_timeout_s, self.load_timeout_s, w.cpu_seconds(),
                         start + self.load_wall_s)

    # --- evaluation -------------------------------------------------------------------------------
    def _faults(self, reason: str, t: float) -> list[Verdict]:
        reason = protocol.clean_text(f"fault: {reason}")
        return [Verdict(c.id, c.phase, False, reason, math.nan, t, True) for c in self._constraints]

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
            failed (exception, malformed or non-finite result, deadline, worker crash or restart).
            Whatever the worker does, this returns verdicts: it never raises because of a worker.
        Raises:
            SandboxError: called before :meth:`load`.
            ShapeMismatchError: the inputs have the wrong shapes.
        """
        start = time.perf_counter()
        deadline = start + (self.deadline_s if deadline_s is None else float(deadline_s))
        if self._program is None:
            raise SandboxError("Sandbox.evaluate called before load()")
        t = float(t)
        layout_e, layout_h, data = pack(elements, history, history_t, t)
        w = self._active
        if w is None:  # replaced, and no spare had been started yet
            self._activate_spare()
            return self._faults("monitor worker is restarting", t)
        if not w.ready:
            try:
                self._absorb(w, start)  # only what has already arrived
            except LateError:
                return self._faults("monitor worker is restarting", t)
            except (EOFError, OSError, ReplyError, ProgramError, SandboxError) as exc:
                self._replace(f"replacement failed: {type(exc).__name__}")
                return self._faults(protocol.clean_text(f"monitor worker could not be restarted: {exc}"), t)
        self._seq += 1
        try:
            w.send(pickle.dumps(("eval", self._seq, layout_e, layout_h, data, t), protocol=5), deadline)
            reply = w.recv(deadline)
            results, marks = protocol.decode_result(reply, self._seq, len(self._constraints), self.n_branches,
                                                    self._reasons)
        except LateError:
            ms = (deadline - start) * 1e3
            self._replace(f"deadline {ms:.0f} ms exceeded")
            return self._faults(f"deadline {ms:.0f} ms exceeded", t)
        except ReplyError as exc:
            self._replace(f"malformed reply: {exc}")
            return self._faults(f"monitor worker gave a malformed reply ({exc})", t)
        except (EOFError, OSError) as exc:
            # a worker that closed its socket is exiting: its exit status, if it comes within the deadline
            how = w.how_it_ended(wait_s=max(0.002, deadline - time.perf_counter()))
            self._replace(f"worker died ({how})")
            return self._faults(f"monitor worker died ({how}; {type(exc).__name__})", t)
        self.last_marks = marks
        return [Verdict(c.id, c.phase, ok, reason, margin, t, fault)
                for c, (ok, reason, margin, fault) in zip(self._constraints, results)]
