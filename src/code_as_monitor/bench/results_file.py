"""A results file's two guards: one writer at a time, and the code version of every record.

**Lock.** :class:`ResultsLock` takes an exclusive, non-blocking ``flock`` on the results file for as
long as a sweep appends to it; a second ``cam bench`` on the same file fails at once with a
:class:`~code_as_monitor.core.errors.RunError` naming the file (and the pid of the holder, read from
the file's last ``bench_start``). The kernel drops the lock when its holder dies, however it dies, so
a killed run never leaves a stale lock behind.

**Code version.** :func:`code_version` names the code that produced a record: the package version
plus a content hash of every file of the installed package (sources and simulator assets), e.g.
``"0.1.0+src.3f9a1c0b2d4e"``; :func:`git_describe` adds ``git describe --always --dirty`` of the
package's checkout when there is one (for people; the hash is what is compared). Two checkouts with
the same files get the same version whatever their history. Records written before versions were
recorded take the ``code`` of their session's ``bench_start`` line (a git revision), or
``"unknown"``; they never equal a current version.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import subprocess
from pathlib import Path
from typing import Any

from code_as_monitor.core.errors import RunError

PACKAGE_DIR = Path(__file__).resolve().parents[1]


@functools.lru_cache(maxsize=1)
def src_hash(root: Path = PACKAGE_DIR) -> str:
    """SHA-256 (first 12 hex digits) over the relative path and bytes of every file under ``root``,
    byte-code caches left out."""
    h = hashlib.sha256()
    files = sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                   and p.suffix not in (".pyc", ".pyo"))
    for p in files:
        h.update(p.relative_to(root).as_posix().encode() + b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:12]


def code_version() -> str:
    """``<package version>+src.<content hash>``: what a resumed sweep compares."""
    from code_as_monitor import __version__

    return f"{__version__}+src.{src_hash()}"


@functools.lru_cache(maxsize=1)
def git_describe() -> str | None:
    """``git describe --always --dirty`` of the checkout holding the package, None outside a checkout."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty", "--tags"], cwd=PACKAGE_DIR,
                             capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return out or None


def record_versions(lines: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The lines with every ``episode`` record given a ``code`` (legacy records: their session's)."""
    session = "unknown"
    out = []
    for r in lines:
        if r.get("kind") == "bench_start":
            session = str(r.get("code_version") or r.get("code") or "unknown")
        if r.get("kind") == "episode" and not r.get("code"):
            r = {**r, "code": session}
        out.append(r)
    return out


def versions_of(records: list[dict[str, Any]]) -> dict[str, int]:
    """Code version -> number of records, most frequent first."""
    counts: dict[str, int] = {}
    for r in records:
        v = str(r.get("code") or "unknown")
        counts[v] = counts.get(v, 0) + 1
    return dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))


def _holder_pid(path: Path) -> str:
    """The pid written by the last session that started on ``path`` (best effort, for the message)."""
    try:
        with path.open("rb") as fh:
            fh.seek(max(0, path.stat().st_size - (1 << 16)))
            tail = fh.read().decode("utf-8", "replace")
    except OSError:
        return ""
    import json

    for line in reversed(tail.splitlines()):
        if '"bench_start"' in line:
            try:
                pid = json.loads(line).get("pid")
            except ValueError:
                continue
            return f" (pid {pid})" if pid else ""
    return ""


class ResultsLock:
    """Exclusive lock on a results file for one writer; ``with ResultsLock(path): ...``.

    Creates the file (and its directory) if needed, and removes it again on release if it is still
    empty. Raises RunError when another process holds it.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self._fd: int | None = None
        self._created = False
        self._new_dirs: list[Path] = []

    def acquire(self) -> ResultsLock:
        import fcntl

        self._created = not self.path.exists()
        self._new_dirs = []
        d = self.path.parent.absolute()
        while not d.exists():
            self._new_dirs.append(d)
            d = d.parent
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise RunError(f"results file {self.path} is being written by another cam bench{_holder_pid(self.path)}; "
                           "wait for it to finish or give another --results file") from None
        self._fd = fd
        return self

    def release(self) -> None:
        """Drop the lock; a file this lock created and nobody wrote to (a session that failed before
        its first line) is removed, so a refused run leaves nothing behind."""
        if self._fd is not None:
            if self._created and os.fstat(self._fd).st_size == 0:
                with contextlib.suppress(OSError):
                    self.path.unlink()
                    for d in self._new_dirs:  # deepest first; stops at the first that is not empty
                        d.rmdir()
            os.close(self._fd)  # closing the last descriptor of the open file drops the lock
            self._fd = None

    def __enter__(self) -> ResultsLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


__all__ = ["ResultsLock", "code_version", "git_describe", "record_versions", "src_hash", "versions_of"]
