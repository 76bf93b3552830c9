"""The benchmark runner: episodes to an append-only JSONL results file, with resume.

Results file lines (``kind`` first):

- ``{"kind": "bench_start", "options": {...}, "spec": {...}, "executor": ..., "epoch": ...}`` once per
  session (a resumed run adds another);
- ``{"kind": "episode", ...record}`` for each finished episode (see ``bench.episode``), written and
  flushed as soon as it finishes (``finished_at``: epoch seconds);
- ``{"kind": "bench_end", "wall_s": ..., "episodes": n}`` when a session completes.

Resume: episodes whose key (condition, method, seed, episode) is already in the file without an
``error`` are skipped (errored ones are retried; the last record of a key is the one reported), so
a killed run loses nothing that finished (a truncated last line is ignored by ``read_jsonl`` and cut
before appending). A
file keeps one set of method options: resuming with different options is a ConfigError.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.executors import ExecutorConfig, LocalExecutorConfig, run_tasks
from code_as_monitor.bench.protocol import BenchSpec, Job
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.run_io import EventLog, new_run_dir, read_jsonl

ProgressFn = Callable[[Job, dict[str, Any], int, int], None]


def read_results(path: str | Path) -> list[dict[str, Any]]:
    """Every line of a results file (missing file: empty)."""
    p = Path(path)
    return read_jsonl(p) if p.exists() else []


def episode_records(lines: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The episode records, one per key: the last attempt wins (an errored episode is retried on resume)."""
    seen: dict[tuple, dict[str, Any]] = {}
    for r in lines:
        if r.get("kind") == "episode":
            seen[record_key(r)] = r
    return list(seen.values())


def record_key(r: dict[str, Any]) -> tuple[str, str, int, int]:
    return (r["condition"], r["method"], int(r["seed"]), int(r["episode"]))


def _check_options(lines: list[dict[str, Any]], opts: dict[str, Any]) -> None:
    for r in lines:
        if r.get("kind") == "bench_start" and r.get("options") != opts:
            raise ConfigError(
                f"the results file was made with other method options ({r.get('options')}); use another "
                f"--results file or the same options (now {opts})")


def code_version() -> str:
    """``git describe``-like id of the working tree (``<rev>`` or ``<rev>-dirty``), or ``"unknown"``."""
    import subprocess

    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                             timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
                               text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return rev + ("-dirty" if dirty else "")


def repair_tail(path: str | Path) -> bool:
    """Cut a truncated last line (a killed writer) so that appends start on a fresh line; True if cut."""
    p = Path(path)
    if not p.exists():
        return False
    data = p.read_bytes()
    if not data or data.endswith(b"\n"):
        return False
    with p.open("r+b") as fh:
        fh.truncate(data.rfind(b"\n") + 1)
    return True


def _sample_dir(runs_dir: Path | None, results: Path, job: Job) -> Path | None:
    """A fresh directory for the sample video of seed 0, episode 0 of every (method, condition) cell:
    ``runs_dir/<results stem>/<condition>/<method>-<UTC time>`` (never reused)."""
    if runs_dir is None or job.seed != 0 or job.episode != 0:
        return None
    return new_run_dir(runs_dir / results.stem / job.condition, prefix=job.method)


def run_bench(spec: BenchSpec, results: str | Path, executor: ExecutorConfig | None = None,
              runs_dir: str | Path | None = None, on_result: ProgressFn | None = None,
              on_start: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Run every pending episode of ``spec``, appending records to ``results``.

    Args:
        spec: cells, seeds x episodes and method options (``spec.options`` -> :class:`EpisodeOptions`).
        results: the JSONL results file (created, or resumed when it exists).
        executor: where episodes run (default: local process pool).
        runs_dir: where sample videos go (seed 0, episode 0 of each cell); None for no videos.
        on_result: ``fn(job, record, done, total)`` after each episode (progress bars).
        on_start: ``fn(pending, already_done)`` once before the first episode.
    Returns:
        ``{"ran": n, "skipped": n, "wall_s": s}`` for this session.
    """
    executor = executor or LocalExecutorConfig()
    opts = EpisodeOptions(**spec.options)
    lines = read_results(results)
    repair_tail(results)
    _check_options(lines, opts.to_dict())
    have = {record_key(r) for r in episode_records(lines) if not r.get("error")}
    jobs = [j for j in spec.jobs() if j.key not in have]
    skipped = len(spec.jobs()) - len(jobs)
    if on_start is not None:
        on_start(len(jobs), skipped)
    rdir = Path(runs_dir) if runs_dir is not None else None
    wall0 = time.perf_counter()
    ran = 0
    with EventLog(results, append=True) as log:
        log.write("bench_start", options=opts.to_dict(), executor=executor.to_dict(),
                  spec={"methods": spec.methods, "conditions": spec.conditions, "seeds": spec.seeds,
                        "episodes": spec.episodes}, pending=len(jobs),
                  time=time.strftime("%Y-%m-%dT%H:%M:%S"), epoch=round(time.time(), 1), code=code_version())
        tasks = [(j, opts, _sample_dir(rdir, Path(results), j)) for j in jobs]
        for job, rec in run_tasks(executor, run_episode, tasks):
            log.write("episode", **rec, finished_at=round(time.time(), 1))
            ran += 1
            if on_result is not None:
                on_result(job, rec, ran, len(jobs))
        wall = time.perf_counter() - wall0
        log.write("bench_end", wall_s=round(wall, 2), episodes=ran)
    return {"ran": ran, "skipped": skipped, "wall_s": round(wall, 2)}


__all__ = ["episode_records", "read_results", "record_key", "repair_tail", "run_bench"]
