"""Executors: where benchmark episodes run. Registered choices on :class:`ExecutorConfig`.

- ``local`` (default): a process pool on this machine (``workers`` processes, spawned, so every
  worker owns its own PyBullet client).
- ``ray``: Ray tasks, on a local Ray instance started for the run (default) or on an existing cluster
  (``address``, e.g. ``"ray://head:10001"`` or ``"auto"``). Needs the optional extra: ``pip install
  -e '.[ray]'``.

Both yield ``(job, record)`` as episodes finish, in completion order; a record is a pure function of
(job, options), so the results are the same whichever executor runs them.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from code_as_monitor.core.errors import MissingExtraError
from code_as_monitor.core.registry import Choice, check_positive

Task = tuple[Any, Any, Path | None]  # (job, options, video dir)
Worker = Callable[[Any, Any, Path | None], dict[str, Any]]


@dataclass
class ExecutorConfig(Choice):
    """Base of the executor configs. ``workers``: episodes run at once (0 = one per CPU)."""

    workers: int = 0

    def __post_init__(self) -> None:
        check_positive(type(self).__name__, "workers", self.workers, allow_zero=True)

    def n_workers(self) -> int:
        return self.workers or max(1, os.cpu_count() or 1)


@ExecutorConfig.register("local")
@dataclass
class LocalExecutorConfig(ExecutorConfig):
    """A local process pool (``workers=1`` runs in this process, handy for debugging)."""


@ExecutorConfig.register("ray")
@dataclass
class RayExecutorConfig(ExecutorConfig):
    """Ray. ``address``: None starts a local instance; otherwise the cluster to connect to."""

    address: str | None = None


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


def _run_local(cfg: ExecutorConfig, fn: Worker, tasks: list[Task]) -> Iterator[tuple[Any, dict[str, Any]]]:
    n = min(cfg.n_workers(), len(tasks))
    if n == 1:
        for t in tasks:
            yield t[0], fn(*t)
        return
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    with ProcessPoolExecutor(max_workers=n, mp_context=mp.get_context("spawn")) as pool:
        pending = {pool.submit(fn, *t): t[0] for t in tasks}
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    job = pending.pop(fut)
                    yield job, fut.result()
        finally:
            for fut in pending:
                fut.cancel()


def _run_ray(cfg: RayExecutorConfig, fn: Worker, tasks: list[Task]) -> Iterator[tuple[Any, dict[str, Any]]]:
    ray = require_ray()
    started = False
    if not ray.is_initialized():
        if cfg.address:
            ray.init(address=cfg.address, log_to_driver=False)
        else:
            ray.init(num_cpus=cfg.n_workers(), include_dashboard=False, log_to_driver=False)
        started = True
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
            ray.cancel(ref)
        if started:
            ray.shutdown()


__all__ = ["ExecutorConfig", "LocalExecutorConfig", "RayExecutorConfig", "require_ray", "run_tasks"]
