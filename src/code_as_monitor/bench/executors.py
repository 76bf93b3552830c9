"""Executors: where benchmark episodes run. Registered choices on :class:`ExecutorConfig`.

- ``local`` (default): a process pool on this machine (``workers`` processes, spawned, so every
  worker owns its own PyBullet client).
- ``ray``: Ray tasks, on a local Ray instance started for the run (default) or on an existing cluster
  (``address``, e.g. ``"ray://head:10001"`` or ``"auto"``). Needs the optional extra: ``pip install
  -e '.[ray]'``.

Both yield ``(job, record)`` as episodes finish, in completion order; a record is a pure function of
(job, options), so the results are the same whichever executor runs them.

Lifetime: no worker outlives the process that started it. Local pool workers ask the kernel to kill
them when their parent dies (``PR_SET_PDEATHSIG`` on Linux) and also watch their parent pid from a
thread (any platform), so a ``kill -9`` of ``cam bench`` takes its workers with it; they ignore
SIGINT (a Ctrl-C reaches the whole process group: the parent alone decides) and, when the parent
stops iterating (Ctrl-C, SIGTERM turned into an exception, an error while writing results), the pool
is cancelled and its workers terminated at once instead of finishing their episodes. The
multiprocessing resource tracker exits when the last of them is gone. A local Ray instance started
here is shut down the same way; its processes are started fate-sharing with this one (Ray's own
``PR_SET_PDEATHSIG``), so they also go when it is killed.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from code_as_monitor.core.checks import check_count
from code_as_monitor.core.errors import ConfigError, MissingExtraError, RunError
from code_as_monitor.core.registry import Choice

Task = tuple[Any, Any, Path | None]  # (job, options, video dir)
Worker = Callable[[Any, Any, Path | None], dict[str, Any]]


@dataclass
class ExecutorConfig(Choice):
    """Base of the executor configs. ``workers``: episodes run at once (0 = one per CPU)."""

    workers: int = 0

    def __post_init__(self) -> None:
        check_count(type(self).__name__, "workers", self.workers, 0)

    def n_workers(self) -> int:
        return self.workers or usable_cpus()


@ExecutorConfig.register("local")
@dataclass
class LocalExecutorConfig(ExecutorConfig):
    """A local process pool (``workers=1`` runs in this process, handy for debugging)."""


@ExecutorConfig.register("ray")
@dataclass
class RayExecutorConfig(ExecutorConfig):
    """Ray. ``address``: None starts a local instance; otherwise the cluster to connect to (``auto``,
    ``host:port`` or ``ray://host:port``)."""

    address: str | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.address is not None and not (
                self.address == "auto" or re.fullmatch(r"(ray://)?[A-Za-z0-9_.\-\[\]:]+:\d{1,5}", self.address)):
            raise ConfigError(f"RayExecutorConfig.address must be auto, host:port or ray://host:port, "
                              f"got {self.address!r}")


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the platform has one, e.g. a container
    pinned to some cores of a larger host), else the machine's count: one episode per usable core keeps
    them all busy without oversubscribing them."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def require_ray() -> Any:
    """Import ray or raise MissingExtraError naming the extra."""
    try:
        import ray
    except ImportError as exc:
        raise MissingExtraError("the ray executor needs the optional extra: pip install -e '.[ray]'") from exc
    return ray


def run_tasks(cfg: ExecutorConfig, fn: Worker, tasks: list[Task]) -> Iterator[tuple[Any, dict[str, Any]]]:
    """Run ``fn(*task)`` for every task on the executor ``cfg``; yields (job, record) as each finishes."""
    if not tasks:
        return
    if isinstance(cfg, RayExecutorConfig):
        yield from _run_ray(cfg, fn, tasks)
    else:
        yield from _run_local(cfg, fn, tasks)


WATCH_S = 0.5
"""How often a pool worker checks that its parent is still alive (the backstop to PR_SET_PDEATHSIG)."""


def die_with_parent(parent_pid: int) -> None:
    """Make this process end when ``parent_pid`` (its parent) ends, however the parent ends.

    Linux: ``prctl(PR_SET_PDEATHSIG, SIGKILL)``, then a check that the parent did not die before the
    call. Everywhere: a daemon thread polling ``os.getppid()`` every ``WATCH_S`` seconds that exits the
    process when the parent pid changes (the process was re-parented).
    """
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent_pid:
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(WATCH_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="parent-watchdog", daemon=True).start()


def _pool_worker_init(parent_pid: int, quiet: bool) -> None:
    """Initializer of every local pool worker (runs in the worker)."""
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if quiet:  # the parent's command line is quiet: so are its workers (no third-party warnings)
        import warnings

        warnings.filterwarnings("ignore")
        logging.getLogger().setLevel(logging.ERROR)


def _terminate_pool(pool: Any) -> None:
    """Cancel what has not started and end the workers now (not after their running episodes)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # shutdown() forgets them
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + 5.0
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join(1.0)


def _run_local(cfg: ExecutorConfig, fn: Worker, tasks: list[Task]) -> Iterator[tuple[Any, dict[str, Any]]]:
    n = min(cfg.n_workers(), len(tasks))
    if n == 1:
        for t in tasks:
            yield t[0], fn(*t)
        return
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    quiet = logging.getLogger().getEffectiveLevel() > logging.INFO
    pool = ProcessPoolExecutor(max_workers=n, mp_context=mp.get_context("spawn"),
                               initializer=_pool_worker_init, initargs=(os.getpid(), quiet))
    finished = False
    try:
        pending = {pool.submit(fn, *t): t[0] for t in tasks}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                job = pending.pop(fut)
                yield job, fut.result()
        finished = True
    finally:
        if finished:
            pool.shutdown(wait=True)
        else:  # interrupted, or the consumer stopped: do not wait for running episodes
            _terminate_pool(pool)


@contextlib.contextmanager
def ray_instance(cfg: RayExecutorConfig) -> Iterator[Any]:
    """Ray, initialised for ``cfg`` for the duration of the block (a local instance, followed by a
    reaper, or a connection to ``cfg.address``); an already initialised Ray is used as it is."""
    ray = require_ray()
    if ray.is_initialized():
        yield ray
        return
    # Ray logs INFO/WARNING lines of its own (a token-authentication notice, "Started a local Ray
    # instance"); keep them unless our logging is verbose.
    level = logging.INFO if logging.getLogger().getEffectiveLevel() <= logging.INFO else logging.ERROR
    reaper = None
    try:
        if cfg.address:
            try:
                ray.init(address=cfg.address, log_to_driver=False, logging_level=level)
            except Exception as exc:  # Ray raises ConnectionError, RuntimeError, ValueError ...
                raise RunError(f"cannot connect to the Ray cluster at {cfg.address!r}: {exc}") from exc
        else:
            from code_as_monitor.bench.reaper import Reaper, children_of

            reaper = Reaper()  # follows the local instance's processes, ends them if we die
            before = children_of(os.getpid())
            ray.init(num_cpus=cfg.n_workers(), include_dashboard=False, log_to_driver=False, logging_level=level)
            reaper.watch(children_of(os.getpid()) - before - {reaper.proc.pid})
        yield ray
    finally:
        if ray.is_initialized():
            ray.shutdown()
        if reaper is not None:
            reaper.close()  # whatever of the instance outlived ray.shutdown (its agents) goes now


def executor_session(cfg: ExecutorConfig) -> contextlib.AbstractContextManager[Any]:
    """Start what ``cfg`` needs before any task (Ray: the instance or the connection), so that a
    failure to start comes before the caller writes anything; :func:`run_tasks` inside the block
    reuses it. The local pool needs nothing up front."""
    if isinstance(cfg, RayExecutorConfig):
        return ray_instance(cfg)
    return contextlib.nullcontext()


def _run_ray(cfg: RayExecutorConfig, fn: Worker, tasks: list[Task]) -> Iterator[tuple[Any, dict[str, Any]]]:
    with ray_instance(cfg) as ray:
        refs: dict[Any, Any] = {}
        try:
            remote = ray.remote(num_cpus=1)(fn)
            refs = {remote.remote(*t): t[0] for t in tasks}
            while refs:
                done, _ = ray.wait(list(refs), num_returns=1)
                for ref in done:
                    job = refs.pop(ref)
                    yield job, ray.get(ref)
        finally:
            for ref in list(refs):
                ray.cancel(ref, force=True)


__all__ = ["ExecutorConfig", "LocalExecutorConfig", "RayExecutorConfig", "executor_session", "ray_instance",
           "require_ray", "run_tasks"]
