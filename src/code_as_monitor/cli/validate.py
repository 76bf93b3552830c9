"""Argument validation for every ``cam`` command: numbers, paths and files, checked while parsing.

Every check here runs before a command creates anything (a run directory, a results file, a worker):
a bad value ends the command with one line on stderr and exit status 2.

- :class:`CamArgumentParser` turns argparse's usage-plus-error into that one line.
- Argument types (``type=`` of ``add_argument``): :func:`seed`, :func:`count`, :func:`number`,
  :func:`probability`, :func:`json_object`, :func:`csv`, and for paths :func:`input_file`, :func:`input_path`,
  :func:`output_dir`, :func:`new_file`, :func:`results_file`. A string ``default`` goes through the
  type too, so default paths are checked like given ones.
- The same path checks as functions raising :class:`~code_as_monitor.core.errors.ConfigError`
  (:func:`check_input_file`, :func:`check_output_dir`, :func:`check_new_file`,
  :func:`check_results_file`) for paths derived from other arguments after parsing.
- :func:`check_namespace`: the net under all of them, run on every parsed command line: no float
  argument may be NaN or inf, no path may hold a NUL byte.

Writability is probed, not guessed from permission bits: a temporary file is created in the nearest
existing ancestor and removed at once, so a read-only file system, a missing permission, and a path
running through a regular file are all found up front (and root is treated like anyone else).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from code_as_monitor.core.checks import SEED_MAX, check_count, check_range, check_seed
from code_as_monitor.core.errors import ConfigError

ArgType = Callable[[str], Any]


class CamArgumentParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line: ``cam sim: error: argument --seed: ... (see --help)``."""

    def error(self, message: str) -> NoReturn:
        sys.stderr.write(f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")
        sys.exit(2)


def _arg_type(name: str, check: Callable[[str], Any]) -> ArgType:
    """Wrap ``check`` (which raises ConfigError) as an argparse type (which raises ArgumentTypeError)."""

    def convert(text: str) -> Any:
        try:
            return check(text)
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    convert.__name__ = name
    return convert


def _parse_number(text: str, integer: bool) -> Any:
    try:
        return int(text, 10) if integer else float(text)
    except ValueError:
        raise ConfigError(f"expected {'an integer' if integer else 'a number'}, got {text!r}") from None


def _check_seed_text(text: str) -> int:
    value = _parse_number(text, True)
    if not 0 <= value <= SEED_MAX:
        raise ConfigError(f"a seed must be an integer in [0, {SEED_MAX}], got {text}")
    return check_seed("", value)


seed: ArgType = _arg_type("seed", _check_seed_text)


def count(minimum: int = 1, maximum: int | None = None) -> ArgType:
    """An integer ``>= minimum`` (and ``<= maximum``: episodes, seeds, workers, retries)."""

    def check(text: str) -> int:
        value = _parse_number(text, True)
        if value < minimum:
            raise ConfigError(f"must be an integer >= {minimum}, got {text}")
        if maximum is not None and value > maximum:
            raise ConfigError(f"must be an integer in [{minimum}, {maximum}], got {text}")
        return check_count("", "", value, minimum)

    return _arg_type(f"count>={minimum}", check)


def number(lo: float | None = None, hi: float | None = None, lo_open: bool = False) -> ArgType:
    """A finite float in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``); NaN and inf are refused."""

    def check(text: str) -> float:
        value = _parse_number(text, False)
        if not math.isfinite(value):
            raise ConfigError(f"must be a finite number, got {text}")
        try:
            return check_range("", "", value, lo, hi, lo_open=lo_open)
        except ConfigError as exc:  # drop the empty owner prefix: "must be > 0, got -1.0"
            raise ConfigError(str(exc).lstrip(". ")) from None

    return _arg_type("number", check)


probability: ArgType = number(0.0, 1.0)
positive: ArgType = number(0.0, None, lo_open=True)
non_negative: ArgType = number(0.0, None)


def _json_object(text: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"expected a JSON object, got {text!r} ({exc.msg})") from None
    if not isinstance(value, dict):
        raise ConfigError(f"expected a JSON object ({{...}}), got {text!r}")
    return value


json_object: ArgType = _arg_type("json_object", _json_object)


def _csv(text: str) -> list[str]:
    items = [x.strip() for x in text.split(",") if x.strip()]
    if not items:
        raise ConfigError(f"expected a comma-separated list, got {text!r}")
    return items


csv: ArgType = _arg_type("csv", _csv)


# ----- paths ---------------------------------------------------------------------------------------

def _who(flag: str, path: Path) -> str:
    return f"{flag} {path}" if flag else str(path)


def _path(text: str | os.PathLike[str], flag: str) -> Path:
    s = os.fspath(text)
    if not s or "\x00" in s:
        raise ConfigError(f"{flag + ': ' if flag else ''}not a usable path: {s!r}")
    return Path(s)


def _probe_writable(directory: Path, flag: str, target: Path) -> None:
    """Create and remove a temporary file in ``directory``; ConfigError naming ``target`` if that fails."""
    try:
        fd, name = tempfile.mkstemp(prefix=".cam-write-probe-", dir=directory)
    except OSError as exc:
        raise ConfigError(f"{_who(flag, target)}: cannot write in {directory} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(name)


def _existing_ancestor(path: Path, flag: str, target: Path) -> Path:
    """The nearest existing ancestor of ``path`` (itself included), which must be a directory."""
    p = path.absolute()
    while not p.exists():
        if p.is_symlink():
            raise ConfigError(f"{_who(flag, target)}: {p} is a dangling link")
        p = p.parent
    if not p.is_dir():
        raise ConfigError(f"{_who(flag, target)}: {p} is not a directory")
    return p


def check_output_dir(path: str | os.PathLike[str], flag: str) -> Path:
    """A directory that exists and is writable, or can be created (its nearest existing ancestor is a
    writable directory). Nothing is created."""
    p = _path(path, flag)
    if p.exists() and not p.is_dir():
        raise ConfigError(f"{_who(flag, p)}: exists and is not a directory")
    _probe_writable(_existing_ancestor(p, flag, p), flag, p)
    return p


def check_new_file(path: str | os.PathLike[str], flag: str) -> Path:
    """A file to create: it must not exist, and its directory must be writable or creatable."""
    p = _path(path, flag)
    if p.exists() or p.is_symlink():
        raise ConfigError(f"{_who(flag, p)}: already exists; refusing to overwrite it")
    if p.name in ("", ".", ".."):
        raise ConfigError(f"{_who(flag, p)}: not a file name")
    _probe_writable(_existing_ancestor(p.parent, flag, p), flag, p)
    return p


def check_input_file(path: str | os.PathLike[str], flag: str) -> Path:
    """An existing, readable regular file."""
    p = _path(path, flag)
    if not p.exists():
        raise ConfigError(f"{_who(flag, p)}: no such file")
    if p.is_dir():
        raise ConfigError(f"{_who(flag, p)}: is a directory, not a file")
    if not p.is_file():
        raise ConfigError(f"{_who(flag, p)}: not a regular file")
    try:
        with p.open("rb") as fh:
            fh.read(1)
    except OSError as exc:
        raise ConfigError(f"{_who(flag, p)}: cannot read it ({exc.strerror or exc})") from None
    return p


def check_input_path(path: str | os.PathLike[str], flag: str) -> Path:
    """An existing, readable file or directory (a rosbag2 bag is either)."""
    p = _path(path, flag)
    if p.is_dir():
        try:
            os.listdir(p)
        except OSError as exc:
            raise ConfigError(f"{_who(flag, p)}: cannot read the directory ({exc.strerror or exc})") from None
        return p
    return check_input_file(p, flag)


def check_results_file(path: str | os.PathLike[str], flag: str) -> Path:
    """A JSONL results file to append to (resume) or create: an existing regular file we can open for
    appending, or a new one in a writable (or creatable) directory."""
    p = _path(path, flag)
    if p.exists():
        if not p.is_file():
            raise ConfigError(f"{_who(flag, p)}: exists and is not a regular file")
        try:
            with p.open("ab"):
                pass
        except OSError as exc:
            raise ConfigError(f"{_who(flag, p)}: cannot append to it ({exc.strerror or exc})") from None
        return p
    _probe_writable(_existing_ancestor(p.parent, flag, p), flag, p)
    return p


def _path_type(name: str, check: Callable[[str, str], Path]) -> ArgType:
    return _arg_type(name, lambda text: check(text, ""))


input_file: ArgType = _path_type("input_file", check_input_file)
input_path: ArgType = _path_type("input_path", check_input_path)
output_dir: ArgType = _path_type("output_dir", check_output_dir)
new_file: ArgType = _path_type("new_file", check_new_file)
results_file: ArgType = _path_type("results_file", check_results_file)


def parse_settings(items: list[str], flag: str = "--set") -> dict[str, Any]:
    """``KEY=VALUE`` items -> {key: value}, VALUE parsed as JSON, else kept as a string; ConfigError naming a
    malformed item."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, val = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"{flag} expects KEY=VALUE, got {item!r}")
        try:
            out[key.strip()] = json.loads(val)
        except json.JSONDecodeError:
            out[key.strip()] = val
    return out


def check_namespace(args: argparse.Namespace) -> None:
    """The net under every command: no parsed float is NaN or inf, no path holds a NUL byte."""
    for key, val in vars(args).items():
        vals = val if isinstance(val, list) else [val]
        for v in vals:
            flag = "--" + key.replace("_", "-")
            if isinstance(v, float) and not math.isfinite(v):
                raise ConfigError(f"{flag} must be a finite number, got {v}")
            if isinstance(v, Path):
                _path(v, flag)


__all__ = [
    "CamArgumentParser",
    "check_input_file",
    "check_input_path",
    "check_namespace",
    "check_new_file",
    "check_output_dir",
    "check_results_file",
    "count",
    "csv",
    "input_file",
    "input_path",
    "json_object",
    "new_file",
    "non_negative",
    "number",
    "output_dir",
    "positive",
    "probability",
    "results_file",
    "seed",
]
