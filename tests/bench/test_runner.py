"""Runner: results appended per episode, resume after a killed run, option mismatch refused."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from code_as_monitor.bench.executors import LocalExecutorConfig
from code_as_monitor.bench.protocol import BenchSpec
from code_as_monitor.bench.runner import episode_records, read_results, record_key, run_bench
from code_as_monitor.core.errors import ConfigError

pytest.importorskip("pybullet")

SPEC = dict(methods=["open-loop"], conditions=["stack-p0.3"], seeds=1, episodes=5)

CHILD = """
import sys
from code_as_monitor.bench.executors import LocalExecutorConfig
from code_as_monitor.bench.protocol import BenchSpec
from code_as_monitor.bench.runner import run_bench
spec = BenchSpec(methods=["open-loop"], conditions=["stack-p0.3"], seeds=1, episodes=5)
run_bench(spec, sys.argv[1], LocalExecutorConfig(workers=1))
"""


def _episodes(path) -> list[dict]:
    return [r for r in read_results(path) if r["kind"] == "episode"]


def _strip(r: dict) -> dict:
    return {k: v for k, v in r.items() if k not in ("wall_time_s", "cpu_time_s", "finished_at", "reproduce")}


def test_resume_after_a_killed_run_loses_and_repeats_nothing(tmp_path):
    results = tmp_path / "res.jsonl"
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(results)], env=os.environ.copy())
    try:
        deadline = time.time() + 600  # a generous bound, not a timing claim: a loaded machine is slow
        while time.time() < deadline and proc.poll() is None and (not results.exists() or len(_episodes(results)) < 2):
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    before = _episodes(results)
    assert 2 <= len(before) < 5, "the child should have been killed mid-sweep"
    with results.open("a") as fh:  # what a kill in the middle of a write leaves behind
        fh.write('{"kind": "episode", "condition": "stack-p0.3", "meth')
    out = run_bench(BenchSpec(**SPEC), results, LocalExecutorConfig(workers=1))
    assert out["skipped"] == len(before) and out["ran"] == 5 - len(before)
    # The truncated line was cut before appending: every line parses.
    lines = [json.loads(x) for x in results.read_text().splitlines()]
    eps = episode_records(lines)
    assert len(eps) == len([r for r in lines if r["kind"] == "episode"])
    assert sorted(record_key(r) for r in eps) == [("stack-p0.3", "open-loop", 0, e) for e in range(5)]
    # Same records as an uninterrupted run.
    fresh = tmp_path / "fresh.jsonl"
    run_bench(BenchSpec(**SPEC), fresh, LocalExecutorConfig(workers=1))
    by_key = {record_key(r): _strip(r) for r in _episodes(fresh)}
    for r in eps:
        assert _strip(r) == by_key[record_key(r)]


def test_rerun_skips_everything_and_other_options_are_refused(tmp_path):
    results = tmp_path / "res.jsonl"
    spec = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1)
    assert run_bench(spec, results, LocalExecutorConfig(workers=1))["ran"] == 1
    again = run_bench(spec, results, LocalExecutorConfig(workers=1))
    assert again == {**again, "ran": 0, "skipped": 1}
    other = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1,
                      options={"doremi_k_s": 2.0})
    with pytest.raises(ConfigError, match="other method options") as e:
        run_bench(other, results, LocalExecutorConfig(workers=1))
    assert "doremi_k_s: 1.0 in the file, 2.0 now" in str(e.value) and "tracker" not in str(e.value)
    other_tracker = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1,
                              options={"tracker": "depth"})
    with pytest.raises(ConfigError, match=r"tracker: 'sim' in the file, 'depth' now.*add --tracker sim"):
        run_bench(other_tracker, results, LocalExecutorConfig(workers=1))
    rec = _episodes(results)[0]
    for key in ("condition", "method", "seed", "episode", "episode_seed", "success", "sim_time_s", "wall_time_s",
                "cpu_time_s", "images", "vlm", "alarms", "gt", "video", "finished_at"):
        assert key in rec


def test_errored_episodes_are_retried_and_the_last_attempt_counts(tmp_path):
    results = tmp_path / "res.jsonl"
    spec = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1)
    broken = {"kind": "episode", "condition": "stack-p0", "method": "open-loop", "seed": 0, "episode": 0,
              "success": False, "error": "RunError: boom"}
    results.write_text(json.dumps(broken) + "\n")
    assert run_bench(spec, results, LocalExecutorConfig(workers=1))["ran"] == 1
    (rec,) = episode_records(read_results(results))
    assert rec["error"] is None and rec["success"] is True
