"""``cam bench --cameras``: every method runs on the named camera set, the records and report say so, and results
files from before the option resume as each task's own views."""

from __future__ import annotations

import json

import pytest

import code_as_monitor.baselines.vqa as vqa_module
from code_as_monitor.bench.commands import run_command
from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.executors import LocalExecutorConfig
from code_as_monitor.bench.protocol import BenchSpec, Job
from code_as_monitor.bench.report import markdown
from code_as_monitor.bench.runner import read_results, run_bench
from code_as_monitor.core.errors import ConfigError

pytest.importorskip("pybullet")

SHOULDERS = {"shoulder_left", "shoulder_right"}


def test_doremi_asks_its_questions_on_the_shoulder_views(monkeypatch):
    asked: list[str] = []
    real = vqa_module.question_view

    def spy(want, obs):
        assert set(obs.views) == SHOULDERS  # the episode renders the set, not the task's views
        name = real(want, obs)
        asked.append(name)
        return name

    monkeypatch.setattr(vqa_module, "question_view", spy)
    rec = run_episode(Job("doremi", "stack-p0", 0, 0), EpisodeOptions(cameras="shoulders", counterfactual=False))
    assert rec["error"] is None, rec.get("traceback")
    assert asked and set(asked) <= SHOULDERS
    assert rec["vlm"]["calls_by_purpose"].get("vqa", 0) == len(asked)


def test_a_cam_record_carries_the_camera_set_in_its_run_command():
    rec = run_episode(Job("cam", "stack-p0", 0, 0), EpisodeOptions(cameras="shoulders", counterfactual=False))
    assert rec["error"] is None, rec.get("traceback")
    assert "--cameras shoulders" in rec["run"]
    assert "--cameras" not in run_command("stack-in-order", 1, {}, EpisodeOptions().to_dict())


def test_old_results_files_resume_as_the_tasks_own_views_and_another_set_is_refused(tmp_path):
    results = tmp_path / "res.jsonl"
    spec = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1)
    assert run_bench(spec, results, LocalExecutorConfig(workers=1))["ran"] == 1
    lines = [json.loads(x) for x in results.read_text().splitlines()]
    for r in lines:  # as a file written before the option existed
        if r.get("kind") == "bench_start":
            del r["options"]["cameras"]
    results.write_text("".join(json.dumps(r) + "\n" for r in lines))
    assert run_bench(spec, results, LocalExecutorConfig(workers=1))["skipped"] == 1
    other = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1,
                      options={"cameras": "shoulders"})
    with pytest.raises(ConfigError, match="other method options"):
        run_bench(other, results, LocalExecutorConfig(workers=1))
    assert any(r.get("kind") == "bench_start" for r in read_results(results))


def test_the_report_names_the_camera_set():
    def first_line(options: dict) -> str:
        summary = {"methods": [], "conditions": [], "cells": {}, "records": [], "wall_s": 0.0, "options": options,
                   "versions": {}, "ignored": []}
        return markdown(summary, with_paper=False).splitlines()[0]

    assert "Cameras: the `shoulders` set for every method" in first_line(EpisodeOptions(cameras="shoulders").to_dict())
    assert "Cameras" not in first_line(EpisodeOptions().to_dict())
