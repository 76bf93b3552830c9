"""``cam sim``: list, one episode with video + event log, refusal to overwrite, bad options."""

from __future__ import annotations

import json

import pytest

from code_as_monitor.cli.main import main

pytest.importorskip("pybullet")


def test_list_shows_tasks_and_parameters(capsys):
    assert main(["sim", "--list"]) == 0
    out = capsys.readouterr().out
    for s in ("stack-in-order", "sweep-half", "rope-close-square", "p = 0.0", "q = 0.0", "n_blocks = 40"):
        assert s in out


def test_episode_writes_video_and_events_and_refuses_overwrite(tmp_path, capsys):
    video = tmp_path / "out.mp4"
    assert main(["sim", "stack-in-order", "--seed", "0", "--p", "0.3", "--video", str(video),
                 "--camera-hz", "2"]) == 0
    out = capsys.readouterr().out
    events = tmp_path / "out.events.jsonl"
    assert video.stat().st_size > 1000 and events.exists()
    lines = [json.loads(x) for x in events.read_text().splitlines()]
    assert lines and all({"t", "kind", "obj"} <= set(e) for e in lines)
    assert "stack-in-order seed=0" in out and str(events) in out
    assert main(["sim", "stack-in-order", "--video", str(video)]) == 2
    assert "already exists" in capsys.readouterr().err


def test_unknown_task_and_option_exit_2(capsys):
    assert main(["sim", "no-such-task"]) == 2
    assert "no-such-task" in capsys.readouterr().err
    assert main(["sim", "sweep-half", "--p", "0.3"]) == 2
    assert "p" in capsys.readouterr().err
    assert main(["sim", "stack-in-order", "--set", "q=-2"]) == 2
    assert "q" in capsys.readouterr().err
