"""Spare sandbox workers, started by a background thread so that no caller ever waits for a process start.

Starting a worker (``fork``/``exec`` of a Python interpreter) takes milliseconds on an idle machine and
far more on a loaded one; the control loop must not pay that inside a frame. :class:`SparePool` keeps
``n`` workers started: its spawner thread starts a new one whenever one is taken. The workers' parent-
death signal is tied to the thread that started them, so the spawner thread lives until
:meth:`SparePool.close`.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable

from code_as_monitor.core.errors import SandboxError
from code_as_monitor.monitor.process import WorkerProcess


class SparePool:
    """Keeps ``n`` started workers (booting or ready) for :class:`~code_as_monitor.monitor.sandbox.Sandbox`.

    Args:
        n: how many spares to keep.
        make: starts one worker (raises OSError when it cannot).

    Attributes:
        registry: every worker this pool started that has not been forgotten (for last-resort cleanup).
    """

    def __init__(self, n: int, make: Callable[[], WorkerProcess]) -> None:
        self.n = n
        self._make = make
        self._spares: list[WorkerProcess] = []
        self._cond = threading.Condition()
        self._starting = 0
        self._closed = False
        self._error: str | None = None
        self._held = 0  # spares taken whose replacement waits for refill()
        self.registry: list[WorkerProcess] = []
        self._thread = threading.Thread(target=self._run, name="cam-sandbox-spawner", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._closed and (self._error or len(self._spares) + self._starting + self._held >= self.n):
                    self._cond.wait()
                if self._closed:
                    return
                self._starting += 1
            w, err = None, None
            try:
                w = self._make()
            except OSError as exc:
                err = f"cannot start the sandbox worker: {exc}"
            with self._cond:
                self._starting -= 1
                if w is not None:
                    self.registry.append(w)
                    if self._closed:
                        w.kill()
                    else:
                        self._spares.append(w)
                else:
                    self._error = err
                self._cond.notify_all()

    def take(self, timeout: float, refill: bool = True) -> WorkerProcess | None:
        """The oldest spare that has said ready, else the oldest one; waits up to ``timeout`` seconds for
        one to exist (0: not at all) and returns None when none does. Its replacement starts at once, or
        with ``refill=False`` at the next :meth:`refill` (so that it does not compete for the CPU with a
        program being loaded).

        Raises:
            SandboxError: the spawner thread could not start a process (the next call tries again).
        """
        end = time.monotonic() + timeout
        with self._cond:
            while not self._spares:
                if self._error is not None:
                    err, self._error = self._error, None
                    self._cond.notify_all()
                    raise SandboxError(err)
                left = end - time.monotonic()
                if left <= 0 or self._closed:
                    return None
                self._cond.wait(left)
            ready = [w for w in self._spares if w.ready]
            w = ready[0] if ready else self._spares[0]
            self._spares.remove(w)
            if not refill:
                self._held += 1
            self._cond.notify_all()
            return w

    def refill(self) -> None:
        """Start the replacements of the spares taken with ``refill=False``, here, in the caller's thread
        (between subgoals, not while frames are evaluated: the spawner thread would compete with them
        for the GIL)."""
        with self._cond:
            missing = self._held
        made: list[WorkerProcess] = []
        try:
            for _ in range(missing):
                made.append(self._make())
        except OSError as exc:
            with self._cond:
                self._error = f"cannot start the sandbox worker: {exc}"
        with self._cond:
            self._held = 0
            self.registry.extend(made)
            if self._closed:
                for w in made:
                    w.kill()
            else:
                self._spares.extend(made)
            self._cond.notify_all()

    def put_back(self, w: WorkerProcess) -> None:
        """Return an unused worker to the front of the pool."""
        with self._cond:
            self._spares.insert(0, w)
            self._cond.notify_all()

    def forget(self, w: WorkerProcess) -> None:
        """Drop a collected worker from :attr:`registry`."""
        with self._cond, contextlib.suppress(ValueError):
            self.registry.remove(w)

    def close(self) -> list[WorkerProcess]:
        """Stop the spawner thread; the spares (and any worker it starts meanwhile) are returned, killed."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._thread.join(timeout=30.0)
        with self._cond:
            spares, self._spares = self._spares, []
        for w in spares:
            w.kill()
        return spares
