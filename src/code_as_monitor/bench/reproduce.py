"""Reproduce a benchmark record: the command that re-runs it, and the re-run compared with the record.

Every episode record of a results file carries ``reproduce``, ``cam reproduce RESULTS --key KEY`` (KEY is
``condition/method/seed/episode``): it reads the method options from the file's ``bench_start`` line and runs
the same job through the same episode code as ``cam bench``
(the commands are written by :mod:`code_as_monitor.bench.commands`). CaM records also carry ``run``, the ``cam run``
command with the same task, episode seed, task parameters, perception, camera size and rate, backend and
re-plan bound: the same episode, with the live log and a run directory (the benchmark's counterfactual
rollouts run in a forked copy of the episode, so running without them changes nothing; records written
before they did, by rollouts restored in place, match their ``run`` command only up to the first rollout).

A re-run matches its record when the outcome (success and reason) is the same, the alarms name the same
constraints at the same frames (within one frame period), and the ground-truth failures are the same events.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from code_as_monitor.bench.commands import parse_key, record_key_text, reproduce_command, run_command
from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.metrics import FAILURE_KINDS
from code_as_monitor.bench.protocol import Job
from code_as_monitor.bench.runner import episode_records, read_results, record_key
from code_as_monitor.core.errors import RunError

FAILURE_EVENT_KINDS = tuple(dict.fromkeys((*FAILURE_KINDS, "regrasped", "block_fell", "placement_noise")))
"""Ground-truth kinds compared between a record and its re-run: every failure kind the metrics count (one list,
:data:`~code_as_monitor.bench.metrics.FAILURE_KINDS`) and the events that settle or cause them."""


def find_record(results: str | Path, key: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """(method options from the file's ``bench_start``, the last record of ``key``); RunError when absent."""
    want = parse_key(key)
    lines = read_results(results)
    starts = [x for x in lines if x.get("kind") == "bench_start"]
    if not starts:
        raise RunError(f"results {results}: no bench_start line (not a cam bench results file?)")
    rec = next((r for r in episode_records(lines) if record_key(r) == want), None)
    if rec is None:
        raise RunError(f"results {results}: no episode record {key!r}")
    return dict(starts[-1].get("options") or {}), rec


@dataclass
class Reproduction:
    """A record and its re-run. ``differences`` is empty when they match (see the module docstring)."""

    record: dict[str, Any]
    rerun: dict[str, Any]
    differences: list[str] = field(default_factory=list)

    @property
    def same(self) -> bool:
        return not self.differences


def _alarm_list(r: dict[str, Any]) -> list[tuple[str, float]]:
    return [(a["constraint_id"], float(a["t"])) for a in r.get("alarms") or []]


def _gt_list(r: dict[str, Any]) -> list[tuple[str, str, float]]:
    return [(e["kind"], e.get("obj", ""), float(e["t"])) for e in r.get("gt") or [] if e["kind"] in FAILURE_EVENT_KINDS]


def compare(record: dict[str, Any], rerun: dict[str, Any], frame_s: float) -> list[str]:
    """What differs between a record and its re-run (empty: the same episode)."""
    diffs = []
    if bool(record.get("success")) != bool(rerun.get("success")) or record.get("reason") != rerun.get("reason"):
        diffs.append(f"outcome: recorded {record.get('success')} ({record.get('reason')!r}), rerun "
                     f"{rerun.get('success')} ({rerun.get('reason')!r})")
    a, b = _alarm_list(record), _alarm_list(rerun)
    if len(a) != len(b) or any(x[0] != y[0] or abs(x[1] - y[1]) > frame_s + 1e-6 for x, y in zip(a, b)):
        diffs.append(f"alarms: recorded {len(a)} {a[:6]}, rerun {len(b)} {b[:6]}")
    g, h = _gt_list(record), _gt_list(rerun)
    if len(g) != len(h) or any(x[:2] != y[:2] or abs(x[2] - y[2]) > frame_s + 1e-6 for x, y in zip(g, h)):
        diffs.append(f"ground truth: recorded {g[:6]}, rerun {h[:6]}")
    return diffs


def reproduce(results: str | Path, key: str, video_dir: Path | None = None) -> Reproduction:
    """Re-run record ``key`` of ``results`` with the file's method options; compare (see :func:`compare`)."""
    options, rec = find_record(results, key)
    condition, method, seed, episode = parse_key(key)
    opts = EpisodeOptions.of_file(options)
    new = run_episode(Job(method=method, condition=condition, seed=seed, episode=episode), opts, video_dir)
    if new.get("error"):
        raise RunError(f"re-run of {key} failed: {new['error']}")
    return Reproduction(rec, new, compare(rec, new, 1.0 / float(opts.camera_hz)))


__all__ = ["Reproduction", "compare", "find_record", "parse_key", "record_key_text", "reproduce", "reproduce_command",
           "run_command"]
