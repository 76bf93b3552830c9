"""The ablation suite's protocol (conditions, methods, settings) and its report table, on constructed records."""

from __future__ import annotations

import pytest

from code_as_monitor.bench.commands import run_command
from code_as_monitor.bench.protocol import ABLATION_METHODS, SUITE_DEFAULTS, SUITES, BenchSpec, ablation_of, is_cam
from code_as_monitor.bench.report_ablation import ablation_markdown, ablation_rows
from code_as_monitor.core.errors import ConfigError


def test_the_suite_is_table2s_book_pen_and_tea_conditions_with_every_setting() -> None:
    assert SUITES["ablation"] == ("book-none", "book-a", "book-b", "book-c", "pen-none", "pen-a", "pen-b", "pen-c",
                                  "tea-none", "tea-a", "tea-b", "tea-c")
    d = SUITE_DEFAULTS["ablation"]
    assert d["episodes"] == 10 and d["seeds"] == 1
    assert d["methods"] == ("cam", *ABLATION_METHODS)
    spec = BenchSpec(methods=list(d["methods"]), conditions=list(SUITES["ablation"]), seeds=1, episodes=10)
    assert len(spec.jobs()) == 6 * 12 * 10


def test_methods_map_to_their_settings() -> None:
    assert ablation_of("cam") == "full" and ablation_of("cam-cs-off") == "cs-off"
    assert is_cam("cam-reactive-only") and not is_cam("doremi") and not is_cam("cam-nothing")
    with pytest.raises(ConfigError, match="doremi"):
        ablation_of("doremi")
    with pytest.raises(ConfigError, match="cam-x"):
        BenchSpec(methods=["cam-x"], conditions=["book-none"])


def test_the_run_command_names_the_setting_only_when_there_is_one() -> None:
    assert "--ablation" not in run_command("stow-book", 3, {}, {})
    assert run_command("stow-book", 3, {"disturbance": "b"}, {}, "mv-off").endswith("--ablation mv-off")


def _rec(cond: str, method: str, ok: bool, t: float = 10.0) -> dict:
    return {"condition": cond, "method": method, "success": ok, "sim_time_s": t, "error": None}


def test_rows_give_rates_per_setting_and_the_average_only_with_all_four() -> None:
    recs = [_rec("book-none", "cam", True), _rec("book-none", "cam", False), _rec("book-a", "cam", True),
            _rec("book-b", "cam", True), _rec("book-c", "cam", False, 20.0),
            _rec("book-none", "cam-mv-off", True), _rec("pen-none", "cam", False)]
    rows = {r["method"]: r for r in ablation_rows(recs, "stow-book")}
    assert rows["cam"]["cells"][0] == (50.0, "50 (1/2)") and rows["cam"]["cells"][3] == (0.0, "0 (0/1)")
    assert rows["cam"]["avg"] == pytest.approx((50 + 100 + 100 + 0) / 4) and rows["cam"]["n"] == 5
    assert rows["cam"]["time"] == pytest.approx(12.0)
    assert rows["cam-mv-off"]["avg"] is None and rows["cam-mv-off"]["cells"][1] is None
    assert [r["method"] for r in ablation_rows(recs, "slot-pen")] == ["cam"]
    assert ablation_rows(recs, "pour-tea") == []


def test_the_paper_rows_name_the_papers_settings_not_ours() -> None:
    text = ablation_markdown({"records": [_rec("book-none", "cam-cs-off", True)], "options": {}})
    ours, paper = text.split("Paper, ablation table", 1)
    assert "| CS off (ORB keypoints, k-means; not DINOv2) | 100 (1/1) |" in ours
    assert "| CS off (DINOv2 points) | 50 | 40 | 40 | 40 | 42.5 |" in paper
    assert "ORB" not in paper


def test_a_closed_loop_episode_carries_its_setting_into_the_monitor_config() -> None:
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig

    assert ClosedLoopConfig(ablation="mv-off").monitor_config().cameras == ["front"]
    assert ClosedLoopConfig(ablation="cs-off").monitor_config().element_source == "orb-keypoints"
    assert ClosedLoopConfig(ablation="cp-off").monitor_config().connect_points is False
    assert ClosedLoopConfig(ablation="proactive-only").monitor_config().checks == "proactive"
    full = ClosedLoopConfig().monitor_config()
    assert (full.cameras, full.element_source, full.connect_points, full.checks) == (None, "part-masks", True, "all")
    with pytest.raises(ConfigError, match="unknown ablation 'nope'"):
        ClosedLoopConfig(ablation="nope")
