"""``cam bench``: list, a one-episode run with resume, bad options exit 2."""

from __future__ import annotations

import json

import pytest

from code_as_monitor.cli.main import main

pytest.importorskip("pybullet")


def test_list(capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out
    assert "stack-p0.15" in out and "rope-close-square" in out and "doremi" in out


def test_tiny_run_then_resume(tmp_path, capsys):
    res = tmp_path / "r.jsonl"
    args = ["bench", "--methods", "open-loop", "--conditions", "stack-p0", "--seeds", "1", "--episodes", "1",
            "--workers", "1", "--results", str(res), "--runs-dir", str(tmp_path / "runs")]
    assert main(args) == 0
    eps = [json.loads(x) for x in res.read_text().splitlines() if '"episode"' in x]
    assert len(eps) == 1 and eps[0]["success"] is True
    assert eps[0]["video"] and list((tmp_path / "runs" / "r" / "stack-p0").glob("open-loop-*/episode.mp4"))
    capsys.readouterr()
    assert main(args) == 0
    assert "0 episode(s) run, 1 skipped" in capsys.readouterr().out


def test_bad_options_exit_2(tmp_path, capsys):
    assert main(["bench", "--methods", "nope", "--results", str(tmp_path / "r.jsonl")]) == 2
    assert "nope" in capsys.readouterr().err
    assert main(["bench", "--executor", "dask", "--results", str(tmp_path / "r.jsonl")]) == 2
    assert "dask" in capsys.readouterr().err
