"""``cam run`` / ``cam demo``: bad input is one line on stderr, exit 2, and no run directory."""

from __future__ import annotations

from pathlib import Path

import pytest

from code_as_monitor.cli.main import main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "nosuch-task"], "unknown TaskConfig 'nosuch-task'"),
        (["run", "stack-in-order", "--tracker", "foo"], "unknown TrackerConfig 'foo'"),
        (["run", "stack-in-order", "--segmenter", "bar"], "unknown SegmenterConfig 'bar'"),
        (["run", "stack-in-order", "--backend", "nope"], "unknown VLMBackendConfig 'nope'"),
        (["run", "stack-in-order", "--p", "2"], "argument --p: must be in [0, 1], got 2"),
        (["run", "stack-in-order", "--size", "12"], "--size must look like 640x480"),
        (["demo", "--backend", "replay"], "--backend replay needs --cassette"),
    ],
)
def test_bad_input_is_one_line_exit_2_and_leaves_no_run(tmp_path: Path, capsys, argv, message) -> None:
    runs = tmp_path / "runs"
    assert main([*argv, "--runs", str(runs)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not runs.exists() or not any(runs.iterdir())


def test_run_quick_episode_writes_a_fresh_run_dir(tmp_path: Path, capsys) -> None:
    pytest.importorskip("pybullet")
    runs = tmp_path / "runs"
    argv = ["run", "stack-in-order", "--seed", "0", "--tracker", "sim", "--size", "160x120", "--no-video",
            "--runs", str(runs), "--quiet"]
    assert main(argv) == 0
    (run_dir,) = runs.iterdir()
    assert {"events.jsonl", "summary.json", "ground_truth.jsonl", "programs", "prompts"} <= {
        p.name for p in run_dir.iterdir()
    }
    assert "SUCCESS" in capsys.readouterr().out
