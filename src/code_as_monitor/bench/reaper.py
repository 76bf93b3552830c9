"""A watchdog on the parent pipe: ends a process tree when the process that owns it dies.

Ray's local instance fate-shares its head processes with the driver, but the agents it starts
under the raylet (dashboard agent, runtime-env agent) only notice a dead raylet after a few polls
and a GCS timeout, a minute or two later. :class:`Reaper` closes that gap without touching anything
it was not told about: it starts ``python -m code_as_monitor.bench.reaper``, a small process that

- is given root pids (``watch(pids)``: the processes a call such as ``ray.init`` just started) and
  follows their descendants by polling ``/proc`` every ``POLL_S`` seconds (pid and start time, so a
  reused pid is never mistaken for one of them);
- holds the read end of a pipe from its owner. End of file (the owner died, however: SIGKILL
  included) or an ``exit`` line (the owner finished, :meth:`Reaper.close`) makes it kill every
  followed process still alive, then exit. It ignores SIGINT (a Ctrl-C is the owner's business) and
  treats SIGTERM like end of file.

Linux only (it reads ``/proc``); elsewhere it follows nothing and exits when told.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterable

POLL_S = 0.5


def _stat(pid: int) -> tuple[int, str] | None:
    """(ppid, start time) of a live, non-zombie ``pid``; None otherwise."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            stat = fh.read()
    except OSError:
        return None
    fields = stat[stat.rindex(")") + 2:].split()
    if fields[0] in ("Z", "X"):
        return None
    return int(fields[1]), fields[19]


def children_of(pid: int) -> set[int]:
    """Pids of the live direct children of ``pid`` (empty where ``/proc`` is missing)."""
    out = set()
    try:
        names = os.listdir("/proc")
    except OSError:
        return out
    for d in names:
        if d.isdigit():
            st = _stat(int(d))
            if st is not None and st[0] == pid:
                out.add(int(d))
    return out


class _Tree:
    """The followed processes: pid -> start time, grown by polling."""

    def __init__(self) -> None:
        self.procs: dict[int, str] = {}
        self.lock = threading.Lock()

    def add_roots(self, pids: Iterable[int]) -> None:
        with self.lock:
            for pid in pids:
                st = _stat(pid)
                if st is not None:
                    self.procs[pid] = st[1]

    def poll(self) -> None:
        try:
            table = {int(d): _stat(int(d)) for d in os.listdir("/proc") if d.isdigit()}
        except OSError:
            return
        with self.lock:
            grew = True
            while grew:
                grew = False
                for pid, st in table.items():
                    if st is not None and st[0] in self.procs and pid not in self.procs:
                        self.procs[pid] = st[1]
                        grew = True

    def kill_all(self) -> None:
        with self.lock:
            for pid, start in self.procs.items():
                st = _stat(pid)
                if st is not None and st[1] == start and pid != os.getpid():
                    with contextlib.suppress(OSError):
                        os.kill(pid, signal.SIGKILL)


def main() -> None:
    """Reaper process: ``watch <pid>...`` and ``exit`` lines on stdin; EOF kills the followed tree."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    tree = _Tree()

    def finish(*_: object) -> None:
        tree.poll()
        tree.kill_all()
        os._exit(0)

    signal.signal(signal.SIGTERM, finish)

    def poller() -> None:
        while True:
            tree.poll()
            time.sleep(POLL_S)

    threading.Thread(target=poller, daemon=True).start()
    for line in sys.stdin:
        words = line.split()
        if words[:1] == ["watch"]:
            tree.add_roots(int(w) for w in words[1:] if w.isdigit())
            tree.poll()
        elif words[:1] == ["exit"]:
            break
    finish()


class Reaper:
    """Owner side: start the reaper, tell it what to follow, close it when done."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "code_as_monitor.bench.reaper"],
                                     stdin=subprocess.PIPE, text=True, close_fds=True)

    def watch(self, pids: Iterable[int]) -> None:
        """Follow ``pids`` and everything they start."""
        assert self.proc.stdin is not None
        self.proc.stdin.write("watch " + " ".join(str(p) for p in pids) + "\n")
        self.proc.stdin.flush()

    def close(self, timeout: float = 10.0) -> None:
        """Kill what is left of the followed processes and wait for the reaper to exit."""
        if self.proc.poll() is None and self.proc.stdin is not None:
            try:
                self.proc.stdin.write("exit\n")
                self.proc.stdin.close()
            except OSError:
                pass
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)


if __name__ == "__main__":
    main()
