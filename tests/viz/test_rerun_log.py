"""``--rerun``: a run saves run.rrd, which rerun's own reader opens offline with every part logged.
Skipped when the optional ``rerun`` extra is not installed."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from code_as_monitor.cli.main import main


def _entities(path: Path) -> Counter:
    from rerun.chunk import RrdReader

    c: Counter = Counter()
    for chunk in RrdReader(path).stream():
        c[str(chunk.entity_path)] += chunk.num_rows
    return c


def test_run_saves_an_rrd_that_opens_offline(tmp_path: Path) -> None:
    pytest.importorskip("rerun")
    pytest.importorskip("pybullet")
    runs = tmp_path / "runs"
    argv = ["run", "stack-in-order", "--seed", "1", "--p", "0.3", "--tracker", "sim", "--size", "160x120",
            "--no-video", "--quiet", "--rerun", "--runs", str(runs)]
    assert main(argv) == 0
    (run_dir,) = runs.iterdir()
    ents = _entities(run_dir / "run.rrd")
    for name in ("/views/front/image", "/views/top/image", "/views/front/elements", "/world/cameras/front",
                 "/world/end_effector", "/events/alarms", "/events/replans", "/events/log"):
        assert ents[name] > 0, (name, sorted(ents))
    assert any(e.startswith("/world/elements/") for e in ents)
    assert ents["/checks/attached_blue_block/margin"] > 5, "a margin timeline per check"
    assert ents["/checks/attached_blue_block/alarm"] == 1, "the drop's alarm marked on its check"


def test_rerun_without_the_extra_is_one_line_exit_2(tmp_path: Path, capsys, monkeypatch) -> None:
    monkeypatch.setitem(__import__("sys").modules, "rerun", None)  # as if rerun-sdk were not installed
    runs = tmp_path / "runs"
    assert main(["run", "stack-in-order", "--rerun", "--runs", str(runs)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'rerun' extra" in err[0]
    assert not runs.exists()
