"""The benchmark runner: episodes to an append-only JSONL results file, with resume.

Results file lines (``kind`` first):

- ``{"kind": "bench_start", "options": {...}, "spec": {...}, "executor": ..., "epoch": ...}`` once per
  session (a resumed run adds another);
- ``{"kind": "episode", ...record}`` for each finished episode (see ``bench.episode``), written and
  flushed as soon as it finishes (``finished_at``: epoch seconds);
- ``{"kind": "bench_end", "wall_s": ..., "episodes": n}`` when a session completes.

Every episode record carries ``reproduce``, the ``cam reproduce`` command that re-runs it (CaM records
also ``run``, the equivalent ``cam run``; see ``bench.commands``), and ``code``, the version of the code
that made it (package version + content hash of the package, see ``bench.results_file``); ``bench_start``
also records ``git`` (``git describe``) and the writer's ``pid``.

Resume: episodes whose key (condition, method, seed, episode) is already in the file without an
``error`` and made by the current code version are skipped; errored ones and ones made by another
code version are run again (``keep_stale=True`` keeps the latter), and the last record of a key is
the one reported. A killed run loses nothing that finished (a truncated last line is ignored by
``read_jsonl`` and cut before appending). A file keeps one set of method options: resuming with
different options is a ConfigError. One writer at a time: the file is locked for the session (a
second writer gets a RunError).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from code_as_monitor.bench.commands import reproduce_command
from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.executors import ExecutorConfig, LocalExecutorConfig, executor_session, run_tasks
from code_as_monitor.bench.protocol import BenchSpec, Job
from code_as_monitor.bench.results_file import ResultsLock, code_version, git_describe, record_versions
from code_as_monitor.core.errors import ConfigError, RunError
from code_as_monitor.core.run_io import EventLog, new_run_dir, read_jsonl

ProgressFn = Callable[[Job, dict[str, Any], int, int], None]


REQUIRED_KEYS = ("condition", "method", "seed", "episode", "success")
"""Keys every episode record must have (a file without them is not a ``cam bench`` results file)."""


def read_results(path: str | Path) -> list[dict[str, Any]]:
    """Every line of a results file (missing file: empty), episode records given their ``code`` version.

    Raises RunError naming the file and line for a directory, an unreadable file, a line that is not
    a JSON object, or an episode record without the keys of ``REQUIRED_KEYS`` (or with a non-integer
    seed or episode).
    """
    p = Path(path)
    if not p.exists():
        return []
    if not p.is_file():
        raise RunError(f"results {p}: not a regular file")
    try:
        lines = read_jsonl(p)
    except (OSError, UnicodeDecodeError) as exc:
        raise RunError(f"results {p}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    for i, r in enumerate(lines):
        if not isinstance(r, dict):
            raise RunError(f"results {p}: record {i + 1} is not a JSON object")
        if r.get("kind") == "episode":
            missing = [k for k in REQUIRED_KEYS if k not in r]
            if missing:
                raise RunError(f"results {p}: episode record {i + 1} lacks {', '.join(missing)}; "
                               "not a cam bench results file?")
            if not all(isinstance(r[k], int) and not isinstance(r[k], bool) for k in ("seed", "episode")):
                raise RunError(f"results {p}: episode record {i + 1} has a non-integer seed or episode")
    return record_versions(lines)


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
    """ConfigError unless every session of the file ran with ``opts``; an option added since a file was made
    counts as its default there (a file from before ``cameras`` ran on each task's own views)."""
    for r in lines:
        if r.get("kind") != "bench_start":
            continue
        made = EpisodeOptions.of_file(r.get("options") or {}).to_dict()
        if made != opts:
            differ = "; ".join(f"{k}: {made.get(k)!r} in the file, {opts.get(k)!r} now"
                               for k in sorted(set(made) | set(opts)) if made.get(k) != opts.get(k))
            hint = (f" (add --tracker {made.get('tracker')}: `cam bench` tracked with the oracle `sim` by default "
                    "until 2026-11-29, with `depth` since)" if made.get("tracker") != opts.get("tracker") else
                    f" (add --robot-visual {made.get('robot_visual')}: the arm was drawn with its full meshes until "
                    "2026-12-02, decimated since)" if made.get("robot_visual") != opts.get("robot_visual") else "")
            raise ConfigError(f"the results file was made with other method options ({differ}); use another "
                              f"--results file or the same options{hint}")


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
              on_start: Callable[[int, int], None] | None = None, keep_stale: bool = False) -> dict[str, Any]:
    """Run every pending episode of ``spec``, appending records to ``results``.

    Args:
        spec: cells, seeds x episodes and method options (``spec.options`` -> :class:`EpisodeOptions`).
        results: the JSONL results file (created, or resumed when it exists).
        executor: where episodes run (default: local process pool).
        runs_dir: where sample videos go (seed 0, episode 0 of each cell); None for no videos.
        on_result: ``fn(job, record, done, total)`` after each episode (progress bars).
        on_start: ``fn(pending, already_done)`` once before the first episode.
        keep_stale: keep finished episodes made by another code version instead of running them again.
    Returns:
        ``{"ran": n, "skipped": n, "stale": n, "wall_s": s}`` for this session (``stale``: records of
        another code version run again, or kept with ``keep_stale``).
    Raises:
        RunError: another process is writing ``results``, or it is not a results file.
        ConfigError: ``results`` was made with other method options.
    """
    executor = executor or LocalExecutorConfig()
    opts = EpisodeOptions(**spec.options)
    version = code_version()
    with ResultsLock(results):
        lines = read_results(results)
        _check_options(lines, opts.to_dict())
        repair_tail(results)
        done = [r for r in episode_records(lines) if not r.get("error")]
        stale = {record_key(r) for r in done if r.get("code") != version}
        have = {record_key(r) for r in done} - (set() if keep_stale else stale)
        jobs = [j for j in spec.jobs() if j.key not in have]
        skipped = len(spec.jobs()) - len(jobs)
        n_stale = len(stale & {j.key for j in spec.jobs()})
        if on_start is not None:
            on_start(len(jobs), skipped)
        rdir = Path(runs_dir) if runs_dir is not None else None
        wall0 = time.perf_counter()
        ran = 0
        with executor_session(executor), EventLog(results, append=True) as log:
            log.write("bench_start", options=opts.to_dict(), executor=executor.to_dict(),
                      spec={"methods": spec.methods, "conditions": spec.conditions, "seeds": spec.seeds,
                            "episodes": spec.episodes}, pending=len(jobs), keep_stale=keep_stale,
                      time=time.strftime("%Y-%m-%dT%H:%M:%S"), epoch=round(time.time(), 1),
                      code_version=version, git=git_describe(), pid=os.getpid())
            tasks = [(j, opts, _sample_dir(rdir, Path(results), j)) for j in jobs]
            for job, rec in run_tasks(executor, run_episode, tasks):
                log.write("episode", **rec, code=version, finished_at=round(time.time(), 1),
                          reproduce=reproduce_command(results, rec))
                ran += 1
                if on_result is not None:
                    on_result(job, rec, ran, len(jobs))
            wall = time.perf_counter() - wall0
            log.write("bench_end", wall_s=round(wall, 2), episodes=ran)
    return {"ran": ran, "skipped": skipped, "stale": n_stale, "wall_s": round(wall, 2)}


__all__ = ["REQUIRED_KEYS", "episode_records", "read_results", "record_key", "repair_tail", "run_bench"]
