"""The report refuses episode records whose values it cannot read, naming the record and the field."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from code_as_monitor.cli.main import main

GOOD = {"kind": "episode", "condition": "stack-p0", "method": "cam", "seed": 0, "episode": 0, "success": True,
        "sim_time_s": 1.0, "vlm": {"calls": 0, "total_tokens": 0}, "alarms": [{"t": 0.5}],
        "gt": [{"t": 0.4, "kind": "drop"}]}
BAD = [({"success": "yes"}, "success"), ({"success": None}, "success"), ({"sim_time_s": math.nan}, "sim_time_s"),
       ({"sim_time_s": "x"}, "sim_time_s"), ({"sim_time_s": -1}, "sim_time_s"), ({"vlm": [1]}, "vlm"),
       ({"vlm": {"calls": "x", "total_tokens": 0}}, "vlm.calls"), ({"alarms": "x"}, "alarms"),
       ({"alarms": [{"t": "x"}]}, "alarms[0]"), ({"alarms": [{"t": 1.0, "cf": 3}]}, "alarms[0].cf"),
       ({"gt": 3}, "gt"), ({"gt": [{"t": 1.0}]}, "gt[0]"), ({"seed": -1}, "seed"), ({"condition": 3}, "condition"),
       ({"method": None}, "method")]


@pytest.mark.parametrize(("change", "field"), BAD, ids=[f for _, f in BAD])
def test_a_bad_value_is_one_line_exit_2_naming_the_field(tmp_path: Path, capsys, change: dict, field: str) -> None:
    f = tmp_path / "r.jsonl"
    f.write_text(json.dumps({**GOOD, **change}) + "\n")
    assert main(["report", str(f), "--out", str(tmp_path / "rep")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"episode record 1: {field}" in err[0], err
    assert not (tmp_path / "rep").exists()


def test_the_good_record_is_reported(tmp_path: Path) -> None:
    f = tmp_path / "r.jsonl"
    f.write_text(json.dumps(GOOD) + "\n")
    assert main(["report", str(f), "--out", str(tmp_path / "rep")]) == 0


def test_an_episode_that_raised_has_no_time_and_is_still_reported(tmp_path: Path, capsys) -> None:
    """``run_episode`` records an exception with ``sim_time_s`` None and ``error`` set; the report counts it as a
    failure with an error (the ablation's MV-off rows had two), while a None time without an error stays refused."""
    f = tmp_path / "r.jsonl"
    raised = {**GOOD, "success": False, "sim_time_s": None, "error": "IndexError: index 0 is out of bounds"}
    f.write_text(json.dumps(GOOD) + "\n" + json.dumps({**raised, "episode": 1}) + "\n")
    assert main(["report", str(f), "--out", str(tmp_path / "rep"), "--print"]) == 0
    assert "errors: 1" in capsys.readouterr().out
    f.write_text(json.dumps({**GOOD, "sim_time_s": None}) + "\n")
    assert main(["report", str(f), "--out", str(tmp_path / "rep2")]) == 2
