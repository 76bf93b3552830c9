"""The life cycle of a sandbox's workers: spares, the ready handshake, hand-over, replacement and shutdown.

:class:`WorkerLifecycle` is the part of :class:`~code_as_monitor.monitor.sandbox.Sandbox` that owns
processes. It keeps spares started (:mod:`.pool`; each a fresh :class:`~.process.WorkerProcess`),
reads each one's ``ready`` record and refuses one that could not confine itself unless the caller opted
out, hands the current program to a spare without waiting, kills and collects retired workers, and
stops everything at :meth:`WorkerLifecycle.close` (or, for a sandbox never closed, at garbage
collection). It never waits for a process start inside a frame: a replaced worker's program is sent to
a spare, and the sandbox answers "restarting" until that spare has loaded it.
"""

from __future__ import annotations

import logging
import pickle
import time
import weakref

from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.errors import ProgramError, SandboxError
from code_as_monitor.monitor import protocol
from code_as_monitor.monitor.pool import SparePool
from code_as_monitor.monitor.process import LateError, WorkerProcess
from code_as_monitor.monitor.protocol import ReplyError

log = logging.getLogger("code_as_monitor.monitor.sandbox")

MAX_START_FAILURES = 3
ALLOW_UNCONFINED_ENV = "CAM_ALLOW_UNCONFINED"
_CONFINED = protocol.SECCOMP | protocol.NO_NEW_PRIVS


def _shutdown(pools: list[SparePool]) -> None:
    """Last-resort cleanup of a sandbox that was never closed: stop its spawner, kill its workers."""
    for pool in pools:
        pool.close()
        for w in list(pool.registry):
            w.kill()


class WorkerLifecycle:
    """The workers of one sandbox: the active one (running the loaded program), the spares and the dying.

    Args:
        memory_mb, cpu_s: each worker's resource limits (see :class:`~.sandbox.Sandbox`).
        start_timeout_s: CPU seconds a starting worker may use before its ready record is overdue. The wait is
            wall-clock time, extended while the worker has used less CPU than this since it was spawned (a busy
            machine, not the worker, made it late), up to ``start_wall_s`` after the spawn.
        start_wall_s: wall-clock ceiling of that wait, seconds (default: 10 x ``start_timeout_s``).
        spares: workers kept started beyond the active one (>= 1).
        confine: workers install the kernel confinement.
        allow_unconfined: a worker that could not confine itself may still run programs (explicit opt-out).

    Attributes:
        n_restarts: workers replaced after a late, malformed or missing reply.
    """

    def __init__(self, memory_mb: int, cpu_s: int, start_timeout_s: float, spares: int, confine: bool,
                 allow_unconfined: bool, start_wall_s: float | None = None) -> None:
        self.memory_mb = int(memory_mb)
        self.cpu_s = int(cpu_s)
        self.start_timeout_s = float(start_timeout_s)
        self.start_wall_s = max(self.start_timeout_s,
                                10.0 * self.start_timeout_s if start_wall_s is None else float(start_wall_s))
        self.n_spares = int(spares)
        self.confine = bool(confine)
        self.allow_unconfined = bool(allow_unconfined)
        self._active: WorkerProcess | None = None
        self._pool: SparePool | None = None  # started on first use
        self._dying: list[WorkerProcess] = []
        self._program: tuple[str, list[Constraint], bool] | None = None  # what a replacement reloads
        self._max_reply = 8192
        self._start_failures = 0
        self.n_restarts = 0
        self._pools: list[SparePool] = []
        self._finalizer = weakref.finalize(self, _shutdown, self._pools)

    # --- workers ----------------------------------------------------------------------------------
    def _spare_pool(self) -> SparePool:
        if self._pool is None:
            memory_mb, cpu_s, confine = self.memory_mb, self.cpu_s, self.confine
            self._pool = SparePool(self.n_spares, lambda: WorkerProcess(memory_mb, cpu_s, confine))
            self._pools.append(self._pool)
        return self._pool

    def _take_spare(self, timeout: float, refill: bool = True) -> WorkerProcess | None:
        """A started spare (waiting up to ``timeout`` for one; None if there is none by then)."""
        self._collect()
        return self._spare_pool().take(timeout, refill)

    def _retire(self, w: WorkerProcess | None) -> None:
        if w is not None:
            w.kill()
            self._dying.append(w)

    def _collect(self) -> None:
        """Reap retired workers that have exited (never waits)."""
        for w in [w for w in self._dying if w.reap(0.0)]:
            self._dying.remove(w)
            if self._pool is not None:
                self._pool.forget(w)

    def _absorb(self, w: WorkerProcess, deadline: float) -> None:
        """Read the replies ``w`` still owes until the deadline (raises :class:`LateError` at it)."""
        while w.awaiting:
            data = w.recv(deadline)
            if w.awaiting[0] == "ready":
                self._on_ready(w, data)
            else:
                ok, value = protocol.decode_load(data)
                if not ok:
                    raise ProgramError(f"monitor program failed to load in the sandbox: {value}")
                w.n_branches = int(value)
            w.awaiting.pop(0)

    def _on_ready(self, w: WorkerProcess, data: bytes) -> None:
        pid, flags, boot_ms, confine_ms, notes = protocol.decode_ready(data)
        if pid != w.pid:
            raise ReplyError(f"ready record names pid {pid}, the worker is {w.pid}")
        w.confinement, w.boot_ms, w.confine_ms = (flags, notes), boot_ms, confine_ms
        w.ready_s = time.perf_counter() - w.started
        if self.confine and flags & _CONFINED != _CONFINED and not self.allow_unconfined:
            raise SandboxError(
                f"the sandbox worker could not be confined by the kernel ({notes}); generated code does not "
                f"run unconfined unless you opt out explicitly: Sandbox(allow_unconfined=True), "
                f"MonitorRuntime(allow_unconfined=True) or {ALLOW_UNCONFINED_ENV}=1")
        if self.confine and flags & _CONFINED != _CONFINED:
            log.warning("sandbox worker runs WITHOUT kernel confinement (opted out): %s", notes)

    def _absorb_cpu(self, w: WorkerProcess, deadline: float, cpu_budget_s: float, cpu0: float,
                    ceiling: float) -> None:
        """Read ``w``'s owed replies until ``deadline`` (wall), then on while the worker has used less than
        ``cpu_budget_s`` of CPU time since ``cpu0`` (its CPU seconds then), until ``ceiling`` (wall); raises
        :class:`LateError` past either (where CPU time cannot be read, at ``deadline``). A busy machine, not the
        worker, makes a reply late when the worker has not had the CPU."""
        while True:
            try:
                self._absorb(w, deadline)
                return
            except LateError:
                used, now = w.cpu_seconds() - cpu0, time.perf_counter()
                if not used < cpu_budget_s or now >= ceiling:  # NaN: not known
                    raise
                deadline = min(ceiling, now + cpu_budget_s - used)

    def _absorb_ready(self, w: WorkerProcess, deadline: float) -> None:
        """Wait for ``w``'s ready record: ``start_timeout_s`` of its CPU time since its spawn, within
        ``start_wall_s`` of wall time after the spawn (:meth:`_absorb_cpu`). Under load a worker that boots in
        half a second of CPU can wait tens of seconds for a core."""
        self._absorb_cpu(w, deadline, self.start_timeout_s, 0.0, w.started + self.start_wall_s)

    def _ready_worker(self, deadline: float, refill: bool = True) -> WorkerProcess:
        """A spare that has said ready (started if need be), replacing ones that die on the way up."""
        while True:
            w = self._take_spare(max(0.0, deadline - time.perf_counter()), refill)
            if w is None:
                raise SandboxError(f"no sandbox worker started within {self.start_timeout_s:.1f} s")
            try:
                self._absorb_ready(w, deadline)
                self._start_failures = 0
                return w
            except SandboxError:
                self._retire(w)
                raise
            except LateError:
                self._retire(w)
                raise SandboxError(f"sandbox worker not ready after {self.start_timeout_s:.1f} s of CPU time "
                                   f"({self.start_wall_s:.0f} s wall at most)") from None
            except (EOFError, OSError, ReplyError) as exc:
                why = f"{type(exc).__name__}: {exc}; {w.how_it_ended()}"
                self._retire(w)
                self._start_failures += 1
                if self._start_failures >= MAX_START_FAILURES:
                    raise SandboxError(f"sandbox worker failed to start {self._start_failures} times: {why}") from None

    def start(self) -> WorkerLifecycle:
        """Make sure a spare is ready (and a replacement worker has reloaded the program).

        Raises:
            SandboxError: no worker came up within ``start_timeout_s``, or it could not be confined (and
                the caller did not opt out).
        """
        deadline = time.perf_counter() + self.start_timeout_s
        w = self._ready_worker(deadline)
        self._spare_pool().put_back(w)
        for _ in range(2 * MAX_START_FAILURES):
            if self._program is None or (self._active is not None and self._active.ready):
                break
            if self._active is None:
                self._activate_spare()
                if self._active is None:
                    w = self._take_spare(max(0.0, deadline - time.perf_counter()))
                    if w is None:
                        raise SandboxError(f"no sandbox worker started within {self.start_timeout_s:.1f} s")
                    self._spare_pool().put_back(w)
                continue
            try:
                self._absorb(self._active, deadline)
            except LateError:
                raise SandboxError(f"replacement worker not ready after {self.start_timeout_s:.1f} s") from None
            except (EOFError, OSError, ReplyError, ProgramError) as exc:
                self._replace(f"replacement worker did not reload the program ({type(exc).__name__})")
        return self

    def close(self) -> None:
        """Stop every worker (SIGKILL) and collect them."""
        workers = [w for w in (self._active, *self._dying) if w is not None]
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.close()
            workers += [w for w in pool.registry if w not in workers]
        self._active, self._dying = None, []
        for w in workers:
            w.kill()
        for w in workers:
            w.reap(timeout=5.0)
        self._pools.clear()

    @property
    def worker_pid(self) -> int | None:
        """Process id of the worker running the current program (None when there is none)."""
        return self._active.pid if self._active is not None and not self._active.dead else None

    @property
    def all_pids(self) -> set[int]:
        """Process ids of every worker this sandbox holds: the active one, the spares, and killed ones not
        yet collected."""
        workers = [self._active, *self._dying, *(self._pool.registry if self._pool is not None else ())]
        return {w.pid for w in workers if w is not None}

    @property
    def confinement(self) -> str:
        """What confines the current (or next) worker, in words; "unknown" before one said ready."""
        for w in (self._active, *(self._pool.registry if self._pool is not None else ())):
            if w is not None and w.confinement is not None:
                return w.confinement[1]
        return "unknown"

    def _replace(self, why: str) -> None:
        """Kill the active worker; a spare takes over the same program (loaded in the background)."""
        log.warning("sandbox worker replaced: %s", why)
        self._retire(self._active)
        self._active = None
        self.n_restarts += 1
        if self._program is not None:
            self._activate_spare()

    def _activate_spare(self) -> None:
        """Hand the current program to a spare without waiting (nothing happens if there is none yet)."""
        try:
            w = self._take_spare(0.0)
        except SandboxError as exc:  # cannot even start a process: try again on the next call
            log.error("no sandbox worker could be started: %s", exc)
            return
        if w is None:
            return
        self._active = w
        try:
            w.send(pickle.dumps(("load", *self._program), protocol=5), time.perf_counter() + 0.05)
            w.awaiting.append("loaded")
            w.allow_reply(self._max_reply)
        except (LateError, OSError):
            self._retire(w)
            self._active = None

