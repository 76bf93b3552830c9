"""One sandbox worker process as the control process sees it: spawn, framed I/O with deadlines, kill.

:class:`WorkerProcess` never blocks past the deadline it is given: the socket is non-blocking and every
wait is a ``poll`` bounded by the time left. Replies are read into one preallocated buffer of a fixed
size, so a worker that announces or sends more than a well-formed reply can hold is cut off (and the
control process's memory does not grow with what a program returns). The worker's stderr goes to an
unlinked temporary file whose size the worker's ``RLIMIT_FSIZE`` bounds; :meth:`WorkerProcess.stderr_tail`
reads its end for crash reports.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import code_as_monitor
from code_as_monitor.monitor import forkserver
from code_as_monitor.monitor.protocol import ReplyError, clean_text

_BOOT = ("import time; t0 = time.perf_counter(); import sys; sys.path.insert(0, sys.argv[1]); "
         "from code_as_monitor.monitor.worker import main; "
         "main(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), t0)")
_SRC_ROOT = str(Path(code_as_monitor.__file__).resolve().parent.parent)
_WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "PATH": os.defpath, "LC_ALL": "C.UTF-8"}
SPAWN_ENV = "CAM_SANDBOX_SPAWN"
SPAWNS = ("fork", "exec")
SPAWN = os.environ.get(SPAWN_ENV, "fork")
"""How workers start: ``fork`` (default) from this process's fork server (:mod:`.forkserver`: one clean
interpreter that imported and warmed up the worker once), ``exec`` a fresh interpreter each (about 0.15
CPU-seconds more per worker; what a replaced :data:`_BOOT` line needs). Set by ``CAM_SANDBOX_SPAWN``."""
_HEADER = struct.Struct("!i")
_POLLIN = select.POLLIN | select.POLLERR | select.POLLHUP
_POLLOUT = select.POLLOUT | select.POLLERR | select.POLLHUP


class LateError(Exception):
    """The worker did not answer (or take the request) before the deadline."""


def _signal_name(code: int) -> str:
    try:
        name = signal.Signals(-code).name
    except ValueError:
        name = f"signal {-code}"
    return f"{name}, a forbidden system call (seccomp)" if name == "SIGSYS" else name


class WorkerProcess:
    """A started worker: the process, its end of the socket pair, its stderr file and a reply buffer.

    Args:
        memory_mb, cpu_s: the worker's resource limits.
        confine: ask the worker to confine itself.
        max_reply: largest reply payload accepted, bytes (grown with :meth:`allow_reply`).
    """

    spin_s = 0.0005
    """Seconds :meth:`recv` looks at the socket before it sleeps in ``poll`` (0: sleep at once)."""

    def __init__(self, memory_mb: int, cpu_s: int, confine: bool, max_reply: int = 8192) -> None:
        parent, child = socket.socketpair()
        self.stderr = tempfile.TemporaryFile(prefix="cam-worker-")  # noqa: SIM115 (closed by reap)
        self.started = time.perf_counter()
        if SPAWN not in SPAWNS:
            raise OSError(f"{SPAWN_ENV} must be one of {', '.join(SPAWNS)}, got {SPAWN!r}")
        try:
            if SPAWN == "fork":
                server = forkserver.shared_server(_WORKER_ENV, _SRC_ROOT)
                self.proc: subprocess.Popen[bytes] | forkserver.ForkedProcess = server.spawn(
                    child.fileno(), self.stderr.fileno(), memory_mb, cpu_s, confine)
            else:
                self.proc = subprocess.Popen(
                    [sys.executable, "-I", "-c", _BOOT, _SRC_ROOT, str(child.fileno()), str(memory_mb), str(cpu_s),
                     str(int(confine))],
                    pass_fds=(child.fileno(),), env=_WORKER_ENV, stdin=subprocess.DEVNULL,
                    stdout=subprocess.DEVNULL, stderr=self.stderr, close_fds=True,
                )
        except OSError:
            parent.close()
            self.stderr.close()
            raise
        finally:
            child.close()
        parent.setblocking(False)
        self.sock = parent
        self.poller = select.poll()
        self.poller.register(parent.fileno(), _POLLIN)
        self._buf = bytearray(4 + max_reply)
        self._view = memoryview(self._buf)
        self._start = self._end = 0
        self.pid = self.proc.pid
        self.awaiting: list[str] = ["ready"]  # replies expected before the worker can evaluate
        self.confinement: tuple[int, str] | None = None  # (flags, notes) from its ready record
        self.boot_ms = math.nan
        self.confine_ms = math.nan
        self.ready_s = math.nan  # seconds from spawn to the ready record
        self.n_branches = 0
        self.dead = False

    @property
    def ready(self) -> bool:
        """Nothing more is awaited: the worker can take a request (load or evaluate)."""
        return not self.awaiting and not self.dead

    def allow_reply(self, max_reply: int) -> None:
        """Make room for replies of up to ``max_reply`` payload bytes (between requests only)."""
        if 4 + max_reply > len(self._buf):
            pending = bytes(self._view[self._start:self._end])
            self._view.release()
            self._buf = bytearray(4 + max_reply)
            self._buf[:len(pending)] = pending
            self._view = memoryview(self._buf)
            self._start, self._end = 0, len(pending)

    # --- I/O --------------------------------------------------------------------------------------
    def send(self, payload: bytes, deadline: float) -> None:
        """Send one framed request; raises :class:`LateError` at the deadline, OSError if the worker is gone."""
        data = memoryview(_HEADER.pack(len(payload)) + payload)
        while data:
            try:
                n = self.sock.send(data)
            except BlockingIOError:
                self._wait(_POLLOUT, deadline)
                continue
            data = data[n:]

    def _wait(self, events: int, deadline: float) -> None:
        """Wait for ``events`` until the deadline (past it: only look, without waiting)."""
        left = deadline - time.perf_counter()
        self.poller.modify(self.sock.fileno(), events)
        try:
            if not self.poller.poll(max(0, math.ceil(left * 1e3))):
                raise LateError
        finally:
            self.poller.modify(self.sock.fileno(), _POLLIN)

    def recv(self, deadline: float) -> bytes:
        """One reply payload. Raises :class:`LateError` at the deadline, :class:`ReplyError` for a frame larger
        than allowed, EOFError/OSError when the worker is gone.

        For its first :attr:`spin_s` seconds the wait is a busy look at the socket (non-blocking reads),
        then a ``poll`` until the deadline: a reply that takes a fraction of a millisecond is then read
        without the control process being put to sleep and woken again, which on an idle machine cost
        more than the reply itself. The look is bounded, so at 10 Hz it costs at most ``spin_s`` of CPU
        per frame."""
        buf = self._buf
        spin_end: float | None = None
        while True:
            avail = self._end - self._start
            if avail >= 4:
                (size,) = _HEADER.unpack_from(buf, self._start)
                if size < 0 or 4 + size > len(buf):
                    raise ReplyError(f"reply of {size} bytes announced; at most {len(buf) - 4} accepted")
                if avail >= 4 + size:
                    s = self._start + 4
                    msg = bytes(self._view[s:s + size])
                    self._start = s + size
                    if self._start == self._end:
                        self._start = self._end = 0
                    return msg
                if self._start + 4 + size > len(buf):  # the frame fits only from the front
                    buf[:avail] = buf[self._start:self._end]
                    self._start, self._end = 0, avail
            elif self._start and self._end == len(buf):
                buf[:avail] = buf[self._start:self._end]
                self._start, self._end = 0, avail
            try:
                n = self.sock.recv_into(self._view[self._end:])
            except BlockingIOError:
                now = time.perf_counter()
                if spin_end is None:
                    spin_end = min(deadline, now + self.spin_s)
                if now < spin_end:  # a reply due within microseconds: look again rather than sleep,
                    os.sched_yield()  # but never hold a core the worker may be waiting for
                    continue
                self._wait(_POLLIN, deadline)
                continue
            if n == 0:
                raise EOFError("worker closed its socket")
            self._end += n

    # --- end of life ------------------------------------------------------------------------------
    def kill(self) -> None:
        """SIGKILL the worker and close its socket (not waiting; :meth:`reap` collects it)."""
        if not self.dead:
            self.dead = True
            with contextlib.suppress(OSError):
                self.proc.kill()
            with contextlib.suppress(OSError):
                self.sock.close()

    def reap(self, timeout: float = 0.0) -> bool:
        """Collect the exit status (waiting up to ``timeout``); True once the process is gone."""
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return False
        with contextlib.suppress(OSError):
            self.stderr.close()
        return True

    def cpu_seconds(self) -> float:
        """CPU seconds (user + system) the worker has used so far, from ``/proc/<pid>/stat``; NaN where
        that cannot be read (not Linux, or the process is gone)."""
        return forkserver.proc_cpu_seconds(self.pid)

    def how_it_ended(self, wait_s: float = 0.0) -> str:
        """"killed by SIGSEGV", "exit code 1", or "still running" (after waiting up to ``wait_s`` for it
        to end), plus the end of its stderr if any."""
        try:
            code = self.proc.wait(timeout=wait_s) if wait_s > 0 else self.proc.poll()
        except subprocess.TimeoutExpired:
            code = None
        if code is None:
            how = "still running"
        elif code < 0:
            how = f"killed by {_signal_name(code)}"
        else:
            how = f"exit code {code}"
        tail = self.stderr_tail(160)
        return f"{how}; stderr: {tail}" if tail else how

    def stderr_tail(self, n: int = 300) -> str:
        """The last ``n`` characters the worker wrote to stderr, cleaned (see ``protocol.clean_text``)."""
        try:
            size = os.fstat(self.stderr.fileno()).st_size
            data = os.pread(self.stderr.fileno(), 4 * n, max(0, size - 4 * n))
        except (OSError, ValueError):
            return ""
        text = data.decode("utf-8", "replace").strip()
        return clean_text(text[-n:], n)
