"""A fork server for sandbox workers: one clean interpreter imports and warms up what a worker needs once,
then forks a fresh worker for every request.

Starting a worker as a new interpreter costs about 0.15 CPU-seconds (``numpy``, the helpers, the warm-up),
paid again for every program; a monitored stacking episode loads 10-20 programs. A fork of an interpreter
that has already done that work costs a few milliseconds and gives the same process image, so every
program still runs in a process of its own that no earlier program touched: the server itself never
runs generated code, never receives any (it is told only the limits and the two descriptors of each
worker) and holds nothing but the worker's modules. Each forked worker then confines itself exactly as
an exec-started one does (:func:`~code_as_monitor.monitor.worker.main`: limits, death signal tied to the
server, seccomp); the server's own death signal is tied to the control-process thread that started it.
Workers forked from one server share its address-space layout (a fork does not re-randomise it).

Exit statuses: the server keeps each exited worker as a zombie (it looks with ``WNOWAIT``) until the
control process has read the status and released it, so a worker's pid cannot be reused while the
control process may still signal it. :class:`ForkedProcess` gives the control side the part of
``subprocess.Popen`` that :class:`~code_as_monitor.monitor.process.WorkerProcess` uses.

Wire format (``SOCK_SEQPACKET``, one message per packet): spawn ``S`` (id, memory MiB, CPU s, confine)
with the worker's socket and stderr descriptors attached; release ``R`` (pid); the server answers
``P`` (id, pid) and reports ``X`` (pid, returncode as ``Popen`` gives it: minus the signal number).
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable

_REQ = struct.Struct("!cQiii")  # kind, id, memory_mb, cpu_s, confine
_REL = struct.Struct("!cQ")  # kind, pid
_REP = struct.Struct("!cQq")  # kind, id or pid, pid or returncode
SPAWN_TIMEOUT_S = 30.0
"""Wall seconds :meth:`ForkServer.spawn` waits for the server's answer before it gives up (OSError)."""


# --- the server (runs in its own interpreter) -------------------------------------------------------
def serve(fd: int, parent: int) -> None:
    """Server entry point: arm the death signal, import and warm up the worker once, then fork workers on
    request from socket ``fd`` until the control process (pid ``parent``) closes it."""
    from code_as_monitor.monitor.confine import PR_SET_PDEATHSIG, _libc

    _libc().prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)  # die with the thread that started us
    if os.getppid() != parent:
        os._exit(0)
    from code_as_monitor.monitor import worker
    from code_as_monitor.monitor.warmup import warm_up

    warm_up()
    sock = socket.socket(fileno=fd)
    wake_r, wake_w = os.pipe()
    os.set_blocking(wake_w, False)
    signal.set_wakeup_fd(wake_w)
    signal.signal(signal.SIGCHLD, lambda *_: None)  # a handler, so that the wakeup fd hears of it
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    live: set[int] = set()  # forked, exit not yet reported
    zombies: set[int] = set()  # exit reported, not yet released
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    poller.register(wake_r, select.POLLIN)
    while True:
        try:
            events = poller.poll()
        except InterruptedError:
            continue
        for ev_fd, _ in events:
            if ev_fd == wake_r:
                with contextlib.suppress(BlockingIOError):
                    os.read(wake_r, 512)
                continue
            try:
                msg, fds, _, _ = socket.recv_fds(sock, 64, 2)
            except InterruptedError:
                continue
            if not msg:
                return  # the control process is gone (or closed us): the workers die with us
            if msg[:1] == b"S" and len(msg) == _REQ.size and len(fds) == 2:
                _, rid, memory_mb, cpu_s, confine = _REQ.unpack(msg)
                pid = _fork_worker(worker.main, fds, [fd, wake_r, wake_w], memory_mb, cpu_s, confine)
                for f in fds:
                    os.close(f)
                if pid > 0:
                    live.add(pid)
                sock.send(_REP.pack(b"P", rid, pid))
            elif msg[:1] == b"R" and len(msg) == _REL.size:
                (_, pid) = _REL.unpack(msg)
                if pid in zombies:
                    zombies.discard(pid)
                    with contextlib.suppress(ChildProcessError):
                        os.waitpid(pid, 0)
            else:
                for f in fds:
                    os.close(f)
        for pid in list(live):
            code = _exit_code(pid)
            if code is not None:
                live.discard(pid)
                zombies.add(pid)
                sock.send(_REP.pack(b"X", pid, code))


def _exit_code(pid: int) -> int | None:
    """``pid``'s returncode (Popen's convention) if it has exited, else None; the zombie is left for release."""
    try:
        info = os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
    except ChildProcessError:
        return -signal.SIGKILL
    if info is None or info.si_pid == 0:
        return None
    if info.si_code == os.CLD_EXITED:
        return info.si_status
    return -info.si_status


def _fork_worker(main: Callable[..., None], fds: list[int], close: list[int], memory_mb: int, cpu_s: int,
                 confine: int) -> int:
    """Fork one worker serving on ``fds[0]`` with stderr ``fds[1]``; returns its pid (-1: fork failed)."""
    try:
        pid = os.fork()
    except OSError:
        return -1
    if pid:
        return pid
    code = 1
    try:  # the child: never returns into the server's loop
        t0 = time.perf_counter()
        signal.set_wakeup_fd(-1)
        signal.signal(signal.SIGCHLD, signal.SIG_DFL)
        for f in close:
            os.close(f)
        os.dup2(fds[1], 2)
        os.close(fds[1])
        main(fds[0], memory_mb, cpu_s, confine, t0, warmed=True)
        code = 0
    except BaseException:  # a worker's last words go to its stderr, then it ends
        with contextlib.suppress(BaseException):
            import traceback

            traceback.print_exc()
    finally:
        os._exit(code)


# --- the control side ---------------------------------------------------------------------------------
class ForkedProcess:
    """A worker forked by a :class:`ForkServer`: the part of ``subprocess.Popen`` the sandbox uses."""

    def __init__(self, server: ForkServer, pid: int) -> None:
        self.server = server
        self.pid = pid
        self.returncode: int | None = None
        self.args = f"<sandbox worker {pid} forked by {server.pid}>"

    def poll(self) -> int | None:
        """The returncode once the worker has exited, else None (never waits)."""
        if self.returncode is None:
            self.server.pump(0.0)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        """Wait for the worker's exit; raises ``subprocess.TimeoutExpired`` after ``timeout`` seconds."""
        end = None if timeout is None else time.monotonic() + timeout
        self.server.pump(0.0)
        while self.returncode is None:
            left = None if end is None else end - time.monotonic()
            if left is not None and left <= 0:
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
            self.server.pump(0.05 if left is None else min(0.05, left))
        return self.returncode

    def kill(self) -> None:
        """SIGKILL the worker (safe while its exit is unread: the server keeps its pid as a zombie)."""
        self.server.signal(self, signal.SIGKILL)


class ForkServer:
    """The control side of one fork-server process (see the module docstring).

    Args:
        env: the server's (and so every worker's) environment.
        src_root: the directory holding the ``code_as_monitor`` package.
    """

    def __init__(self, env: dict[str, str], src_root: str) -> None:
        parent, child = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        boot = ("import sys; sys.path.insert(0, sys.argv[1]); from code_as_monitor.monitor.forkserver import serve; "
                "serve(int(sys.argv[2]), int(sys.argv[3]))")
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-I", "-c", boot, src_root, str(child.fileno()), str(os.getpid())],
                pass_fds=(child.fileno(),), env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, close_fds=True)
        except OSError:
            parent.close()
            raise
        finally:
            child.close()
        self.pid = self.proc.pid
        self.owner_pid = os.getpid()
        self.sock = parent
        self.lock = threading.RLock()
        self.dead = False
        self._next_id = 0
        self._spawned: dict[int, int] = {}
        self._children: dict[int, ForkedProcess] = {}

    def spawn(self, sock_fd: int, stderr_fd: int, memory_mb: int, cpu_s: int, confine: bool) -> ForkedProcess:
        """Fork a worker that serves on ``sock_fd`` and writes to ``stderr_fd`` (both duplicated into it; the
        caller keeps and closes its own). Raises OSError when the server cannot fork or is gone."""
        with self.lock:
            if self.dead:
                raise OSError("the sandbox fork server has ended")
            self._next_id += 1
            rid = self._next_id
            socket.send_fds(self.sock, [_REQ.pack(b"S", rid, memory_mb, cpu_s, int(confine))], [sock_fd, stderr_fd])
        end = time.monotonic() + SPAWN_TIMEOUT_S
        while True:
            with self.lock:
                if rid in self._spawned:
                    pid = self._spawned.pop(rid)
                    if pid <= 0:
                        raise OSError("the sandbox fork server could not fork a worker")
                    proc = ForkedProcess(self, pid)
                    self._children[pid] = proc
                    return proc
                if self.dead or time.monotonic() > end:
                    raise OSError("the sandbox fork server did not answer a spawn request")
            self.pump(min(0.05, max(0.0, end - time.monotonic())))

    def pump(self, timeout: float) -> None:
        """Read what the server has sent, waiting up to ``timeout`` seconds (without the lock) for it."""
        if timeout > 0 and not self.dead:
            with contextlib.suppress(OSError, ValueError):  # closed meanwhile by another thread
                select.select([self.sock], [], [], timeout)
        with self.lock:
            self._pump_locked()

    def _pump_locked(self) -> None:
        """Read every message already there (never waits)."""
        while not self.dead:
            try:
                msg = self.sock.recv(64, socket.MSG_DONTWAIT)
            except BlockingIOError:
                return
            except OSError:
                msg = b""
            if not msg:
                self._ended()
                return
            if len(msg) == _REP.size:
                kind, a, b = _REP.unpack(msg)
                if kind == b"P":
                    self._spawned[a] = b
                elif kind == b"X" and a in self._children:
                    proc = self._children.pop(a)
                    proc.returncode = b
                    with contextlib.suppress(OSError):
                        self.sock.send(_REL.pack(b"R", a))  # the pid may be reused from now on

    def _ended(self) -> None:
        """The server is gone: its workers died with it (death signal); their pids are no longer held."""
        self.dead = True
        for proc in self._children.values():
            proc.returncode = -signal.SIGKILL
        self._children.clear()
        with contextlib.suppress(OSError):
            self.sock.close()

    def signal(self, proc: ForkedProcess, signum: int) -> None:
        """Send ``signum`` to ``proc`` if its exit has not been read (its pid is still its own)."""
        with self.lock:
            self._pump_locked()
            if proc.returncode is None and not self.dead:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(proc.pid, signum)

    def close(self) -> None:
        """End the server (its workers die with it) and collect it."""
        with self.lock:
            if not self.dead:
                self._ended()
        with contextlib.suppress(OSError):
            self.proc.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5)


_server: ForkServer | None = None
_server_lock = threading.Lock()


def shared_server(env: dict[str, str], src_root: str) -> ForkServer:
    """This process's fork server, started on first use (and again after it ended, or in a forked child).

    It is started from a thread of its own that lives as long as the process, because the server's death
    signal fires when the thread that started it ends."""
    global _server
    with _server_lock:
        s = _server
        if s is not None and s.owner_pid == os.getpid() and not s.dead and s.proc.poll() is None:
            return s
        box: list[ForkServer | BaseException] = []
        started = threading.Event()

        def own() -> None:
            try:
                box.append(ForkServer(env, src_root))
            except BaseException as exc:  # handed to the caller
                box.append(exc)
            started.set()
            threading.Event().wait()  # the server's death signal is tied to this thread: never end

        threading.Thread(target=own, name="cam-sandbox-forkserver", daemon=True).start()
        started.wait()
        got = box[0]
        if isinstance(got, BaseException):
            raise got
        _server = got
        return got


def proc_cpu_seconds(pid: int, collected: bool = False) -> float:
    """CPU seconds (user + system) process ``pid`` has used, from ``/proc/<pid>/stat``, with ``collected`` those of
    the children it has waited for too; NaN where that cannot be read (not Linux, or the process is gone)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()  # utime stime cutime cstime are fields 14-17
        return sum(int(x) for x in fields[11:15 if collected else 13]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


def server_cpu_seconds() -> float:
    """CPU seconds used so far by this process's fork server and the workers it has collected (0 when there
    is none): what ``os.times()``'s children fields cannot count, since the server has not exited."""
    s = _server
    if s is None or s.owner_pid != os.getpid() or s.dead:
        return 0.0
    cpu = proc_cpu_seconds(s.pid, collected=True)
    return 0.0 if cpu != cpu else cpu
