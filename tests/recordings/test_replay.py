"""A recorded simulator episode replayed through the monitor raises the live run's alarms."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from conftest import EPISODE

from code_as_monitor.cli.main import main


def _alarms(summary: dict[str, Any]) -> list[tuple[str, float]]:
    return [(a["constraint_id"], float(a["t"])) for a in summary["episode"]["alarms"]]


def test_the_bag_holds_standard_messages(recorded: tuple[Path, dict[str, Any]]) -> None:
    from code_as_monitor.recordings.reader import BagSource

    bag, live = recorded
    src = BagSource(bag)
    types = src.available
    assert types["/cam/front/color/image_raw"] == "sensor_msgs/msg/Image"
    assert types["/cam/front/color/camera_info"] == "sensor_msgs/msg/CameraInfo"
    assert types["/tf_static"] == types["/tf"] == "tf2_msgs/msg/TFMessage"
    assert types["/joint_states"] == "sensor_msgs/msg/JointState"
    assert len(src) == live["bag"]["frames"] and src.stats.dropped_total == 0
    kinds = {e["kind"] for e in src.ground_truth}
    assert "drop" in kinds, "the ground-truth events ride along for scoring"
    obs, _ = src.first
    assert set(obs.views) == {"front", "top"} and obs.views["front"].rgb.shape == (120, 160, 3)
    assert obs.robot is not None and obs.robot.ee_kind == "suction"


def test_replay_gives_the_live_runs_violations(recorded: tuple[Path, dict[str, Any]], tmp_path: Path) -> None:
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig
    from code_as_monitor.bench.replay import replay_bag
    from code_as_monitor.recordings.reader import BagSource

    bag, live = recorded
    src = BagSource(bag)
    cfg = ClosedLoopConfig(**EPISODE).monitor_config(src.metadata["time_limit_s"])
    rep = replay_bag(src, src.metadata["instruction"], cfg, tmp_path, video=False)
    la, ra = _alarms(live), _alarms(rep)
    assert la, "the episode must contain a violation for this test to mean anything"
    assert [c for c, _ in ra] == [c for c, _ in la]
    period = 1.0 / EPISODE.get("camera_hz", 10.0)
    assert all(abs(a - b) <= period + 1e-6 for (_, a), (_, b) in zip(la, ra))
    assert [s["outcome"] for s in rep["episode"]["subgoals"]] == [s["outcome"] for s in live["episode"]["subgoals"]]
    assert rep["outcome"] == "completed" and rep["episode"]["finished"]
    assert (tmp_path / "events.jsonl").exists() and json.loads((tmp_path / "summary.json").read_text())


def test_cam_monitor_writes_a_run_dir(recorded: tuple[Path, dict[str, Any]], tmp_path: Path, capsys) -> None:
    bag, _ = recorded
    runs = tmp_path / "runs"
    assert main(["monitor", str(bag), "--tracker", "sim", "--runs", str(runs)]) == 0  # the live log too
    (run_dir,) = runs.iterdir()
    assert {"events.jsonl", "summary.json", "episode.mp4", "programs", "prompts"} <= {p.name for p in run_dir.iterdir()}
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["frames"]["dropped"] == 0 and summary["frames"]["judged"] > 10
    out = capsys.readouterr().out
    assert "dropped for sync: 0" in out and "COMPLETED" in out


def test_record_refuses_to_overwrite(recorded: tuple[Path, dict[str, Any]], tmp_path: Path, capsys) -> None:
    bag, _ = recorded
    assert main(["record", "stack-in-order", "--out", str(bag), "--runs", str(tmp_path / "r")]) == 2
    assert "already exists" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


@pytest.mark.slow
def test_lk_replay_gives_the_live_runs_violations(tmp_path: Path) -> None:
    """The same with the Lucas-Kanade tracker at 320x240 (slow: a few minutes)."""
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig
    from code_as_monitor.bench.record import record_episode
    from code_as_monitor.bench.replay import replay_bag
    from code_as_monitor.recordings.reader import BagSource

    cfg = ClosedLoopConfig(**{**EPISODE, "tracker": "lk", "width": 320, "height": 240})
    live = record_episode(cfg, tmp_path / "ep.mcap")
    src = BagSource(tmp_path / "ep.mcap")
    rep = replay_bag(src, src.metadata["instruction"], cfg.monitor_config(src.metadata["time_limit_s"]), video=False)
    la, ra = _alarms(live), _alarms(rep)
    assert la and [c for c, _ in ra] == [c for c, _ in la]
    assert all(abs(a - b) <= 0.1 + 1e-6 for (_, a), (_, b) in zip(la, ra))
