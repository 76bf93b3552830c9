"""``cam bench --suite ablation`` on a tiny slice: the ablation settings run as CaM methods, each record names its
setting and the ``cam run`` command that repeats it, and ``cam report`` prints the ablation table beside the
paper's."""

from __future__ import annotations

import json

import pytest

from code_as_monitor.cli.main import main

pytest.importorskip("pybullet")


def test_tiny_ablation_slice_runs_resumes_and_reports(tmp_path, capsys):
    res = tmp_path / "ablation.jsonl"
    args = ["bench", "--suite", "ablation", "--conditions", "book-none", "--methods", "cam-cp-off,cam-proactive-only",
            "--episodes", "1", "--workers", "1", "--no-videos", "--no-counterfactual", "--tracker", "sim",
            "--results", str(res)]
    assert main(args) == 0
    eps = [json.loads(x) for x in res.read_text().splitlines() if '"kind": "episode"' in x or '"kind":"episode"' in x]
    assert sorted(r["method"] for r in eps) == ["cam-cp-off", "cam-proactive-only"]
    for r in eps:
        assert r["error"] is None, r.get("traceback")
        assert r["ablation"] == r["method"][len("cam-"):] and r["tracker"] == "sim"
        assert f"--ablation {r['ablation']}" in r["run"]
    capsys.readouterr()
    assert main(args) == 0
    assert "0 episode(s) run, 2 skipped" in capsys.readouterr().out
    assert main(["report", str(res), "--print"]) == 0
    out = capsys.readouterr().out
    assert "# Ablation" in out and "**stow-book**" in out and "CP off (unconnected points)" in out
    assert "| Full CaM | 70 | 60 | 70 | 60 | 65.0 |" in out, "the paper's row beside ours"
    assert "not a VLM" in out and "oracle" in out


def test_suite_ablation_lists_its_methods_and_refuses_an_unknown_one(tmp_path, capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out
    assert "cam-mv-off" in out and "cam-proactive-only" in out
    assert main(["bench", "--suite", "ablation", "--methods", "cam-dino", "--results", str(tmp_path / "r.jsonl")]) == 2
    assert "cam-dino" in capsys.readouterr().err


def test_cam_run_refuses_an_unknown_ablation(capsys):
    assert main(["run", "stow-book", "--ablation", "dino"]) == 2
    assert "dino" in capsys.readouterr().err
