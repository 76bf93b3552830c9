"""``benchmarks/compare_elements.py`` pairs two ``element_accuracy.py --records`` files element by element."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "compare_elements.py"


def _module():
    spec = importlib.util.spec_from_file_location("compare_elements", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(mod)
    return mod


def _rec(i: int, point_m: float | None, weak: bool = False, unc: float = 0.0, name: str = "book/spine") -> dict:
    return {"i": i, "task": "stow-book", "label": "after_stow", "views": "default", "noise": 2.0, "kind": "point",
            "name": name, "errors": None if point_m is None else {"point": point_m}, "part_unseen": False,
            "weak": weak, "uncertainty": unc}


def _write(path: Path, recs: list[dict]) -> str:
    path.write_text("".join(json.dumps(r) + "\n" for r in recs))
    return str(path)


def test_moved_elements_and_the_painters_verdict_are_counted(tmp_path, capsys) -> None:
    before = [_rec(0, 0.020), _rec(1, 0.001), _rec(2, 0.030, weak=True), _rec(3, None)]
    after = [_rec(0, 0.002), _rec(1, 0.009), _rec(2, 0.030, unc=0.004), _rec(3, 0.001)]
    rc = _module().main([_write(tmp_path / "a.jsonl", before), _write(tmp_path / "b.jsonl", after)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "elements_better: 1 count" in out and "elements_worse: 1 count" in out
    # before: 20 mm unflagged, 30 mm weak; after: 9 mm unflagged, 30 mm with 4 mm uncertainty (under half: unflagged)
    assert "large_errors_flagged_before: 1/2 count" in out
    assert "large_errors_flagged_after: 0/2 count" in out


@pytest.mark.parametrize("other", [[_rec(0, 0.01)], [_rec(0, 0.01, name="book/cover"), _rec(1, 0.01)]])
def test_files_of_other_scenes_are_refused(tmp_path, capsys, other) -> None:
    rc = _module().main([_write(tmp_path / "a.jsonl", [_rec(0, 0.01), _rec(1, 0.01)]),
                         _write(tmp_path / "b.jsonl", other)])
    assert rc == 2
    assert "not the same scenes" in capsys.readouterr().err


@pytest.mark.parametrize("bad", ["missing", "garbled"])
def test_an_unreadable_file_is_one_line_and_exit_2(tmp_path, capsys, bad) -> None:
    a = _write(tmp_path / "a.jsonl", [_rec(0, 0.01)])
    b = tmp_path / "b.jsonl"
    if bad == "garbled":
        b.write_text("{not json\n")
    rc = _module().main([a, str(b)])
    err = capsys.readouterr().err
    assert rc == 2 and "cannot read the records" in err and "b.jsonl" in err
    assert len(err.strip().splitlines()) == 1
