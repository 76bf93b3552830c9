"""The path checks of cli.validate on their own: nothing is created, every refusal names the path."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from code_as_monitor.cli import validate as v
from code_as_monitor.core.errors import ConfigError


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_output_dir_accepts_creatable_paths_without_creating_them(tmp_path: Path) -> None:
    assert v.check_output_dir(tmp_path / "a" / "b", "--out") == tmp_path / "a" / "b"
    assert _tree(tmp_path) == []


@pytest.mark.parametrize(("make", "check", "needle"), [
    (lambda d: (d / "f").write_text("x") and d / "f" / "sub", v.check_output_dir, "is not a directory"),
    (lambda d: (d / "f").write_text("x") and d / "f", v.check_output_dir, "not a directory"),
    (lambda d: (d / "f").write_text("x") and d / "f", v.check_new_file, "already exists"),
    (lambda d: d, v.check_new_file, "already exists"),
    (lambda d: d / "missing", v.check_input_file, "no such file"),
    (lambda d: d, v.check_input_file, "is a directory"),
    (lambda d: d / "missing", v.check_input_path, "no such file"),
    (lambda d: (d / "f").write_text("x") and d / "f" / "r.jsonl", v.check_results_file, "not a directory"),
    (lambda d: d, v.check_results_file, "not a regular file"),
])
def test_refusals_name_the_path(tmp_path: Path, make, check, needle) -> None:
    path = make(tmp_path)
    before = _tree(tmp_path)
    with pytest.raises(ConfigError, match=needle) as err:
        check(path, "--flag")
    assert str(path) in str(err.value) and str(err.value).startswith("--flag ")
    assert _tree(tmp_path) == before


def test_dangling_link_is_refused(tmp_path: Path) -> None:
    (tmp_path / "link").symlink_to(tmp_path / "nowhere")
    with pytest.raises(ConfigError, match="already exists"):
        v.check_new_file(tmp_path / "link", "--video")
    with pytest.raises(ConfigError, match="dangling link"):
        v.check_output_dir(tmp_path / "link" / "x", "--runs")


def test_input_path_takes_files_and_directories(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    assert v.check_input_path(tmp_path, "--bag") == tmp_path
    assert v.check_input_path(tmp_path / "f", "--bag") == tmp_path / "f"


def test_nul_bytes_and_non_finite_floats_are_caught_by_the_namespace_net() -> None:
    with pytest.raises(ConfigError, match="--x must be a finite number"):
        v.check_namespace(argparse.Namespace(x=float("nan")))
    with pytest.raises(ConfigError, match="not a usable path"):
        v.check_namespace(argparse.Namespace(out=Path("a\x00b")))
    v.check_namespace(argparse.Namespace(x=1.0, out=Path("ok"), items=["a"]))
