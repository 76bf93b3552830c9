"""Every benchmark record can be reproduced: ``cam reproduce`` re-runs it through the benchmark's own episode
code, and a CaM record's ``cam run`` command runs the same episode."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from code_as_monitor.bench.reproduce import compare, parse_key, reproduce, reproduce_command
from code_as_monitor.core.errors import ConfigError, RunError

pytest.importorskip("pybullet")

CONDITION = "stack-p0.3"


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    """Three records (open-loop, DoReMi and CaM) of one drop episode, written by the benchmark runner."""
    from code_as_monitor.bench.executors import LocalExecutorConfig
    from code_as_monitor.bench.protocol import BenchSpec
    from code_as_monitor.bench.runner import run_bench

    path = tmp_path_factory.mktemp("bench") / "r.jsonl"
    spec = BenchSpec(methods=["open-loop", "doremi", "cam"], conditions=[CONDITION], seeds=1, episodes=1,
                     options={"tracker": "sim"})
    run_bench(spec, path, LocalExecutorConfig(workers=1))
    return path


def _records(path: Path) -> list[dict]:
    return [r for r in map(json.loads, path.read_text().splitlines()) if r.get("kind") == "episode"]


def test_every_record_carries_its_reproduce_command_and_cam_its_run_command(results):
    recs = _records(results)
    assert len(recs) == 3
    for r in recs:
        assert r["reproduce"] == reproduce_command(results, r)
    cam = next(r for r in recs if r["method"] == "cam")
    assert cam["run"].startswith(f"cam run stack-in-order --seed {cam['episode_seed']} --set p=0.3 ")


@pytest.mark.parametrize("method", ["open-loop", "doremi", "cam"])
def test_three_records_reproduce_their_outcome(results, method):
    rec = next(r for r in _records(results) if r["method"] == method)
    key = rec["reproduce"].split("--key ")[1]
    got = reproduce(results, key)
    assert got.same, got.differences
    assert got.rerun["success"] == rec["success"] and len(got.rerun["alarms"]) == len(rec["alarms"])


def test_the_cam_run_command_runs_the_recorded_episode(results, tmp_path):
    from code_as_monitor.cli.main import main

    rec = next(r for r in _records(results) if r["method"] == "cam")
    words = [*shlex.split(rec["run"])[1:], "--runs", str(tmp_path), "--no-video", "--quiet"]
    code = main(words)
    assert code == (0 if rec["success"] else 1)
    summary = json.loads(next(tmp_path.glob("*/summary.json")).read_text())
    rerun = {"success": summary["success"], "reason": summary["reason"], "alarms": summary["episode"]["alarms"],
             "gt": summary["ground_truth_events"]}
    assert compare(rec, rerun, 0.1) == []


def test_bad_keys_are_named(results):
    with pytest.raises(ConfigError, match="CONDITION/METHOD/SEED/EPISODE"):
        parse_key("stack-p0.3/cam/zero/1")
    with pytest.raises(RunError, match="no episode record"):
        reproduce(results, "stack-p0.3/cam/4/0")


def test_the_run_command_carries_the_suite_replan_bound():
    """The rlbench suite abandons a flagged episode (``max_replans`` 0): its ``cam run`` says so; others keep the
    agents' default."""
    from code_as_monitor.agent.records import DEFAULT_MAX_REPLANS
    from code_as_monitor.bench.commands import run_command

    assert "--max-replans 0 " in run_command("turn-tap", 7, {}, {"max_replans": 0})
    assert f"--max-replans {DEFAULT_MAX_REPLANS} " in run_command("turn-tap", 7, {}, {})


def test_a_rerun_that_differs_in_any_counted_failure_kind_is_reported():
    """Every failure kind the metrics count is compared (an over-sweep or a policy failure included)."""
    from code_as_monitor.bench.metrics import FAILURE_KINDS

    base = {"success": True, "reason": "ok", "alarms": [], "gt": []}
    for kind in FAILURE_KINDS:
        rerun = {**base, "gt": [{"t": 1.0, "kind": kind, "obj": "x"}]}
        assert any(kind in d for d in compare(base, rerun, 0.1)), kind
