"""``--robot-visual``: how the cameras draw the arm (``decimated`` by default; ``mesh``, the full meshes; ``hull``,
its collision meshes) reaches every method's world, the records, their ``cam run`` commands and the report; a bad
name is refused; every default is the simulator's."""

from __future__ import annotations

import pytest

import code_as_monitor.sim.robot as robot_module
from code_as_monitor.bench.closed_loop import ClosedLoopConfig
from code_as_monitor.bench.commands import run_command
from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.protocol import Job
from code_as_monitor.bench.report import markdown
from code_as_monitor.cli import run_cmd
from code_as_monitor.cli.main import build_parser
from code_as_monitor.core.errors import ConfigError

pytest.importorskip("pybullet")


@pytest.fixture
def loaded(monkeypatch) -> list[str]:
    """The visuals of the arms the episode loads."""
    seen: list[str] = []
    real = robot_module.panda_urdf

    def spy(visual: str = robot_module.DEFAULT_ROBOT_VISUAL) -> str:
        seen.append(visual)
        return real(visual)

    monkeypatch.setattr(robot_module, "panda_urdf", spy)
    return seen


@pytest.mark.parametrize("method", ["cam", "doremi"])
def test_every_method_draws_the_arm_as_asked_and_a_cam_record_says_so(method, loaded):
    rec = run_episode(Job(method, "stack-p0", 0, 0), EpisodeOptions(robot_visual="hull", counterfactual=False))
    assert rec["error"] is None, rec.get("traceback")
    assert loaded and set(loaded) == {"hull"}
    if method == "cam":
        assert "--robot-visual hull" in rec["run"]
    assert "--robot-visual" not in run_command("stack-in-order", 1, {}, EpisodeOptions().to_dict())


def test_a_record_from_before_the_field_replays_with_the_full_mesh():
    old = {k: v for k, v in EpisodeOptions().to_dict().items() if k != "robot_visual"}
    assert "--robot-visual mesh" in run_command("stack-in-order", 1, {}, old)
    assert "--robot-visual mesh" in run_command("stack-in-order", 1, {}, EpisodeOptions(robot_visual="mesh").to_dict())


def test_every_default_is_the_simulators():
    parse = build_parser().parse_args
    assert (EpisodeOptions().robot_visual == ClosedLoopConfig().robot_visual
            == run_cmd.config_from_args(parse(["run", "stack-in-order"]), "stack-in-order").robot_visual
            == parse(["bench"]).robot_visual == robot_module.DEFAULT_ROBOT_VISUAL == "decimated")


def test_the_report_names_the_arm_it_drew():
    def first_line(options: dict) -> str:
        summary = {"methods": [], "conditions": [], "cells": {}, "records": [], "wall_s": 0.0, "options": options,
                   "versions": {}, "ignored": []}
        return markdown(summary, with_paper=False).splitlines()[0]

    assert "collision meshes" in first_line(EpisodeOptions(robot_visual="hull").to_dict())
    assert "decimated meshes" in first_line(EpisodeOptions().to_dict())
    assert "full detailed meshes" in first_line({k: v for k, v in EpisodeOptions().to_dict().items()
                                                 if k != "robot_visual"})


def test_a_bad_visual_is_refused_by_name_and_the_flag_reaches_the_config():
    with pytest.raises(ConfigError, match="'shiny'"):
        EpisodeOptions(robot_visual="shiny")
    with pytest.raises(ConfigError, match="'shiny'"):
        ClosedLoopConfig(robot_visual="shiny")
    parse = build_parser().parse_args
    assert run_cmd.config_from_args(parse(["run", "stack-in-order"]), "stack-in-order").robot_visual == "decimated"
    cfg = run_cmd.config_from_args(parse(["run", "stack-in-order", "--robot-visual", "hull"]), "stack-in-order")
    assert cfg.robot_visual == "hull"


def test_a_file_from_before_the_field_ran_with_the_full_mesh_and_resumes_only_so():
    from code_as_monitor.bench.runner import _check_options

    old = {k: v for k, v in EpisodeOptions().to_dict().items() if k != "robot_visual"}
    assert EpisodeOptions.of_file(old).robot_visual == "mesh"
    assert EpisodeOptions.of_file({**old, "robot_visual": "hull"}).robot_visual == "hull"
    lines = [{"kind": "bench_start", "options": old}]
    with pytest.raises(ConfigError, match="add --robot-visual mesh"):
        _check_options(lines, EpisodeOptions().to_dict())
    _check_options(lines, EpisodeOptions(robot_visual="mesh").to_dict())  # the same options: resumes
