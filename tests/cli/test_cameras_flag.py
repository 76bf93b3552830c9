"""``cam run --cameras``: a named camera set for every task, recorded in the run's config, and the monitor
paints, tracks and judges from those views alone."""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, check_choices, run_closed_loop
from code_as_monitor.cli import run_cmd
from code_as_monitor.cli.main import build_parser
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.cameras import CAMERA_SETS, camera_set


def test_every_named_set_is_known_to_the_config_and_task_means_the_tasks_own():
    assert camera_set("task", 320, 240) is None
    for name in CAMERA_SETS:
        check_choices(ClosedLoopConfig(task="stack-in-order", cameras=name))
    assert [c.name for c in camera_set("shoulders", 64, 48)] == ["shoulder_left", "shoulder_right"]
    assert {(c.width, c.height) for c in camera_set("rlbench", 64, 48)} == {(64, 48)}
    with pytest.raises(ConfigError, match="'ceiling'"):
        check_choices(ClosedLoopConfig(task="stack-in-order", cameras="ceiling"))
    with pytest.raises(ConfigError, match="cameras"):
        ClosedLoopConfig(task="stack-in-order", cameras="")


def test_the_flag_reaches_the_config_and_defaults_to_the_tasks_own():
    parse = build_parser().parse_args
    assert run_cmd.config_from_args(parse(["run", "stack-in-order"]), "stack-in-order").cameras == "task"
    cfg = run_cmd.config_from_args(parse(["run", "slot-pen", "--cameras", "front"]), "slot-pen")
    assert cfg.cameras == "front"


def test_an_episode_from_the_shoulders_sees_only_the_shoulders_and_succeeds(tmp_path):
    """Views no default uses, with the depth tracker (no simulator pose): the episode is judged from them."""
    seen: set[str] = set()
    cfg = ClosedLoopConfig(task="stack-in-order", seed=0, tracker="depth", cameras="shoulders", video=False,
                           max_replans=10, deadline_s=0.5)
    out = run_closed_loop(cfg, run_dir=tmp_path,
                          frame_hooks=[lambda obs, *_: seen.update(obs.views)])
    assert seen == {"shoulder_left", "shoulder_right"}
    assert out["config"]["cameras"] == "shoulders"
    assert out["success"], out.get("reason")
    assert sorted(p.name for p in (tmp_path / "prompts").glob("subgoal00_*.png")) == [
        "subgoal00_shoulder_left.png", "subgoal00_shoulder_right.png"]
