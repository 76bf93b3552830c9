"""The ray executor gives the same records as the local one (skipped only without the `ray` extra)."""

from __future__ import annotations

import pytest

from code_as_monitor.bench.executors import ExecutorConfig, LocalExecutorConfig, RayExecutorConfig
from code_as_monitor.bench.protocol import BenchSpec
from code_as_monitor.bench.runner import read_results, record_key, run_bench
from code_as_monitor.core.errors import ConfigError

pytest.importorskip("pybullet")

VOLATILE = ("wall_time_s", "cpu_time_s", "finished_at", "video")


def _records(path) -> dict:
    return {record_key(r): {k: v for k, v in r.items() if k not in VOLATILE}
            for r in read_results(path) if r["kind"] == "episode"}


def test_executor_registry():
    assert set(ExecutorConfig.choices()) >= {"local", "ray"}
    assert isinstance(ExecutorConfig.from_name("ray", address="auto"), RayExecutorConfig)
    with pytest.raises(ConfigError):
        ExecutorConfig.from_name("local", workers=-1)


def test_ray_matches_local_on_a_tiny_sweep(tmp_path):
    pytest.importorskip("ray")
    spec = BenchSpec(methods=["open-loop", "doremi"], conditions=["stack-p0.3"], seeds=1, episodes=1)
    run_bench(spec, tmp_path / "local.jsonl", LocalExecutorConfig(workers=2))  # the process pool
    run_bench(spec, tmp_path / "ray.jsonl", RayExecutorConfig(workers=2))  # a local Ray instance
    local, ray = _records(tmp_path / "local.jsonl"), _records(tmp_path / "ray.jsonl")
    assert len(local) == 2 and local == ray
