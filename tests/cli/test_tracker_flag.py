"""``--tracker depth`` on ``cam run`` / ``cam demo`` / ``cam bench``: accepted, recorded, in the report header."""

from __future__ import annotations

import argparse

import pytest

from code_as_monitor.bench.closed_loop import check_choices
from code_as_monitor.bench.episode import EpisodeOptions
from code_as_monitor.bench.report import markdown
from code_as_monitor.cli import demo_cmd, run_cmd
from code_as_monitor.cli.main import build_parser
from code_as_monitor.core.errors import ConfigError


def _parser() -> argparse.ArgumentParser:
    return build_parser()


@pytest.mark.parametrize("argv", [["run", "stack-in-order"], ["demo"]])
def test_run_and_demo_accept_the_depth_tracker(argv):
    args = _parser().parse_args([*argv, "--tracker", "depth"])
    task = args.task if argv[0] == "run" else demo_cmd.DEMO_TASK
    cfg = run_cmd.config_from_args(args, task)
    assert cfg.tracker == "depth"
    check_choices(cfg)  # registered and valid
    cfg.tracker_options = {"registration": "NDT"}
    with pytest.raises(ConfigError, match="registration"):
        check_choices(cfg)


def test_run_demo_and_bench_default_to_the_depth_tracker():
    """Issue #12 §4: once `depth` is within 5 points of the oracle on every row, it is the default perception of
    `cam demo`, `cam run` and `cam bench` (the oracle stays one flag away: `--tracker sim`)."""
    run = _parser().parse_args(["run", "stack-in-order"])
    assert run_cmd.config_from_args(run, "stack-in-order").tracker == "depth"
    demo = _parser().parse_args(["demo"])
    assert run_cmd.config_from_args(demo, demo_cmd.DEMO_TASK).tracker == "depth"
    assert _parser().parse_args(["bench"]).tracker == "depth"
    assert _parser().parse_args(["bench", "--tracker", "sim"]).tracker == "sim"


def test_bench_records_the_tracker_and_the_report_names_it():
    args = _parser().parse_args(["bench", "--tracker", "depth"])
    opts = EpisodeOptions(tracker=args.tracker)

    def first_line(options: dict) -> str:
        summary = {"methods": [], "conditions": [], "cells": {}, "records": [], "wall_s": 0.0, "options": options,
                   "versions": {}, "ignored": []}
        return markdown(summary, with_paper=False).splitlines()[0]

    assert "tracked by `depth` (no simulator poses)" in first_line(opts.to_dict())
    assert "tracked by `sim` (the oracle" in first_line(EpisodeOptions().to_dict())
