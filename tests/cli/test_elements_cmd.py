"""``cam elements`` end to end through ``cli.main.main``."""

from __future__ import annotations

import re

import pytest

from code_as_monitor.cli.main import main


def test_elements_prints_every_element_with_small_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["elements", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert "seed 1, depth noise 2 mm, outliers 1 %" in out
    for name in ("[0] box top centre (point, box/top)", "[1] box top (surface", "[2] plate surface", "[3] rod axis"):
        assert name in out
    errs = {m[0]: float(m[1]) for m in re.findall(r"(position|normal|direction) ([0-9.]+)", out)}
    assert errs["position"] < 5.0  # mm
    assert errs["normal"] < 3.0 and errs["direction"] < 3.0  # degrees
    assert re.search(r"built 4 elements in [0-9.]+ ms", out)


def test_elements_options_reach_the_scene(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["elements", "--noise-mm", "0", "--outliers", "0"]) == 0
    out = capsys.readouterr().out
    assert "depth noise 0 mm, outliers 0 %" in out
    position = float(re.search(r"position ([0-9.]+) mm", out).group(1))
    assert position < 3.0


@pytest.mark.parametrize(("flag", "value", "message"), [("--outliers", "1.5", "outliers: must be in"),
                                                        ("--noise-mm", "-1", "noise-mm: must be >= 0")])
def test_bad_options_exit_2_with_one_line(
    capsys: pytest.CaptureFixture[str], flag: str, value: str, message: str
) -> None:
    assert main(["elements", flag, value]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_help_lists_the_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["elements", "--help"])
    assert "--noise-mm" in capsys.readouterr().out
