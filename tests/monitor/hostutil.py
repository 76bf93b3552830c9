"""What the tests check about the control process ("the host") after a hostile program has run."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import numpy as np

SLACK_S = 1.0
"""Generous bound on the time past a deadline (a loaded 2-core machine): a containment check, not speed."""
RSS_GROWTH_LIMIT = 64 * 2**20
"""Bytes the host's resident memory may grow by over one hostile program (allocator noise included)."""


def process_state(pid: int) -> str | None:
    """The state letter of a process (R, S, Z ...) or None when it no longer exists."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return None


def wait_gone(pid: int, timeout: float = 5.0) -> bool:
    """True once ``pid`` has exited (gone or a zombie) within ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if process_state(pid) in (None, "Z", "X"):
            return True
        time.sleep(0.01)
    return False


def rss_bytes() -> int:
    """Resident memory of this process."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def live_children() -> list[int]:
    """Pids of this process's children that are running (zombies excluded)."""
    me = os.getpid()
    out = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == me and fields[0] not in ("Z", "X"):
            out.append(int(name))
    return out


def settled_children(others: set[int], known: Callable[[], set[int]], wait_s: float = 5.0,
                     most: int | None = None) -> set[int]:
    """This process's running children that are not in ``others``, once every one of them is in ``known()`` (and,
    with ``most``, there are at most that many) or ``wait_s`` has passed: a spare the sandbox's spawner thread has
    just forked is a child a moment before the sandbox records its pid (seen at load average 30), and a worker it
    killed is a child until it is reaped (4 children against 3 allowed, under two benchmark workers); a worker it
    lost track of, or one it keeps without bound, never gets there."""
    deadline = time.monotonic() + wait_s
    while True:
        ours = set(live_children()) - others
        if (ours <= known() and (most is None or len(ours) <= most)) or time.monotonic() > deadline:
            return ours
        time.sleep(0.05)


def snapshot(arrays: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    return {i: a.copy() for i, a in arrays.items()}


def same(a: dict[int, np.ndarray], b: dict[int, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[i], b[i]) for i in a)
