"""Every command refuses bad input with one line and exit 2, and leaves nothing behind.

Each case runs ``cam`` in-process from an empty working directory (so default output paths such as
``runs/`` land in it) and checks: exit status 2, exactly one line on stderr naming the problem, no
traceback, nothing on stdout, and the directory tree unchanged (no run directory, no results file,
no report). ``UNWRITABLE`` stands for a directory nobody can create files in; ``FILE`` for an existing
regular file; ``DIR`` for an existing directory; ``EMPTY``, ``GARBAGE``, ``NOKEYS``, ``FEWKEYS`` for
results files that are empty, not JSON (``GARBAGE1``: a single complete line), without the episode keys,
without the keys the report reads.
A separate test mounts a real read-only file system (where it is allowed) for the output flags.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from code_as_monitor.cli.main import main

PLAN = "stack the blocks: red at the bottom, then green, then blue"
EP = '{"kind": "episode", "condition": "stack-p0", "method": "cam", "seed": 0, "episode": 0, "success": true}'

CASES: list = [
    # (id, argv, a substring the one line must hold)
    ("run-seed-negative", ["run", "stack-in-order", "--seed", "-1"], "--seed"),
    ("run-seed-text", ["run", "stack-in-order", "--seed", "abc"], "--seed"),
    ("run-seed-float", ["run", "stack-in-order", "--seed", "1.5"], "--seed"),
    ("run-seed-huge", ["run", "stack-in-order", "--seed", str(2**40)], "--seed"),
    ("run-p-above-1", ["run", "stack-in-order", "--p", "2"], "--p"),
    ("run-p-nan", ["run", "stack-in-order", "--p", "nan"], "finite"),
    ("run-q-negative", ["run", "stack-in-order", "--q", "-1"], "--q"),
    ("run-hz-zero", ["run", "stack-in-order", "--camera-hz", "0"], "--camera-hz"),
    ("run-hz-inf", ["run", "stack-in-order", "--camera-hz", "inf"], "finite"),
    ("run-size-bad", ["run", "stack-in-order", "--size", "12"], "--size"),
    ("run-size-tiny", ["run", "stack-in-order", "--size", "8x8"], "width"),
    ("run-replans-negative", ["run", "stack-in-order", "--max-replans", "-1"], "--max-replans"),
    ("run-runs-is-file", ["run", "stack-in-order", "--runs", "FILE"], "not a directory"),
    ("run-runs-unwritable", ["run", "stack-in-order", "--runs", "UNWRITABLE/runs"], "cannot write"),
    ("run-cassette-dir", ["run", "stack-in-order", "--backend", "replay", "--cassette", "DIR"], "is a directory"),
    ("run-cassette-missing", ["run", "stack-in-order", "--backend", "replay", "--cassette", "nope.jsonl"],
     "no such file"),
    ("run-task-unknown", ["run", "no-such-task"], "no-such-task"),
    ("run-tracker-unknown", ["run", "stack-in-order", "--tracker", "foo"], "foo"),
    ("run-cameras-unknown", ["run", "stack-in-order", "--cameras", "ceiling"], "ceiling"),
    ("run-cameras-without-the-ablations-view", ["run", "stack-in-order", "--cameras", "shoulders", "--ablation",
                                                "mv-off"], "shoulders"),
    ("run-unknown-flag", ["run", "stack-in-order", "--frobnicate"], "--frobnicate"),
    ("run-timeout-zero", ["run", "stack-in-order", "--timeout", "0"], "--timeout"),
    ("run-model-empty", ["run", "stack-in-order", "--backend", "openai", "--model", ""], "--model"),
    ("run-api-key-env-for-kb", ["run", "stack-in-order", "--api-key-env", "MY_KEY"], "--api-key-env"),
    ("run-hz-denormal", ["run", "stack-in-order", "--camera-hz", "1e-320"], "--camera-hz"),
    ("run-hz-above-sim-rate", ["run", "stack-in-order", "--camera-hz", "41"], "camera_hz"),
    ("run-deadline-huge", ["run", "stack-in-order", "--deadline", "1e23"], "--deadline"),
    ("run-deadline-denormal", ["run", "stack-in-order", "--deadline", "1e-320"], "--deadline"),
    ("run-size-huge", ["run", "stack-in-order", "--size", "100000x100000"], "--size"),
    ("run-replans-huge", ["run", "stack-in-order", "--max-replans", str(10**23)], "--max-replans"),
    ("run-q-huge", ["run", "stack-in-order", "--q", "1e23"], "q"),
    ("run-set-q-huge", ["run", "stack-in-order", "--set", "q=1e300"], "q"),
    ("run-timeout-huge", ["run", "stack-in-order", "--backend", "openai", "--timeout", "1e23"], "--timeout"),
    ("run-max-tokens-zero", ["run", "stack-in-order", "--max-tokens", "0"], "--max-tokens"),
    ("run-instruction-empty", ["run", "stack-in-order", "--instruction", " "], "--instruction"),
    ("run-instruction-not-understood", ["run", "stack-in-order", "--instruction", "juggle three oranges"],
     "did not understand"),
    ("demo-seed-negative", ["demo", "--seed", "-5"], "--seed"),
    ("demo-p-above-1", ["demo", "--p", "1.5"], "--p"),
    ("demo-runs-unwritable", ["demo", "--runs", "UNWRITABLE/runs"], "cannot write"),
    ("sim-seed-negative", ["sim", "stack-in-order", "--seed", "-1"], "--seed"),
    ("sim-set-text-for-number", ["sim", "stack-in-order", "--set", "p=abc"], "'abc'"),
    ("sim-set-nan", ["sim", "stack-in-order", "--set", "p=NaN"], "finite"),
    ("sim-set-inf", ["sim", "stack-in-order", "--set", "time_limit=Infinity"], "finite"),
    ("sim-set-negative", ["sim", "stack-in-order", "--set", "time_limit=-1"], "time_limit"),
    ("sim-set-unknown-field", ["sim", "stack-in-order", "--set", "colour=3"], "colour"),
    ("sim-set-no-key", ["sim", "stack-in-order", "--set", "=3"], "KEY=VALUE"),
    ("sim-set-bool-for-number", ["sim", "stack-in-order", "--set", "p=true"], "number"),
    ("sim-video-exists", ["sim", "stack-in-order", "--video", "FILE"], "already exists"),
    ("sim-video-unwritable", ["sim", "stack-in-order", "--video", "UNWRITABLE/v.mp4"], "cannot write"),
    ("sim-video-not-mp4", ["sim", "stack-in-order", "--video", "v.avi"], ".mp4"),
    ("sim-events-exists", ["sim", "stack-in-order", "--events", "FILE"], "already exists"),
    ("sim-no-task", ["sim"], "task"),
    ("sim-hz-negative", ["sim", "stack-in-order", "--camera-hz", "-1"], "--camera-hz"),
    ("sim-hz-above-control-rate", ["sim", "stack-in-order", "--camera-hz", "41"], "--camera-hz"),
    ("plan-max-subgoals-zero", ["plan", PLAN, "--max-subgoals", "0"], "--max-subgoals"),
    ("plan-image-missing", ["plan", PLAN, "--image", "front=missing.png"], "cannot read an image"),
    ("plan-image-empty-path", ["plan", PLAN, "--image", "front="], "cannot read an image"),
    ("plan-timeout-negative", ["plan", PLAN, "--timeout", "-1"], "--timeout"),
    ("plan-cassette-missing", ["plan", PLAN, "--backend", "replay", "--cassette", "nope.jsonl"], "no such file"),
    ("plan-record-exists", ["plan", PLAN, "--record", "FILE"], "already exists"),
    ("plan-server-option-for-kb", ["plan", PLAN, "--timeout", "5"], "openai"),
    ("plan-max-retries-negative", ["plan", PLAN, "--backend", "openai", "--max-retries", "-1"], "--max-retries"),
    ("elements-outliers", ["elements", "--outliers", "1.5"], "--outliers"),
    ("elements-noise-nan", ["elements", "--noise-mm", "nan"], "finite"),
    ("elements-seed-negative", ["elements", "--seed", "-1"], "--seed"),
    ("bench-episodes-zero", ["bench", "--seeds", "1", "--episodes", "0"], "--episodes"),
    ("bench-seeds-zero", ["bench", "--seeds", "0"], "--seeds"),
    ("bench-seeds-huge", ["bench", "--seeds", str(10**23)], "--seeds"),
    ("bench-episodes-huge", ["bench", "--episodes", "99999"], "--episodes"),
    ("bench-doremi-k-huge", ["bench", "--doremi-k", "1e23"], "--doremi-k"),
    ("bench-ray-address-empty-without-ray", ["bench", "--ray-address", ""], "--executor ray"),
    ("bench-results-one-garbage-line", ["bench", "--results", "GARBAGE1"], "not valid JSON"),
    ("bench-workers-negative", ["bench", "--workers", "-1"], "--workers"),
    ("bench-method-unknown", ["bench", "--methods", "nope"], "nope"),
    ("bench-condition-unknown", ["bench", "--conditions", "nope"], "nope"),
    ("bench-methods-empty", ["bench", "--methods", ","], "--methods"),
    ("bench-executor-unknown", ["bench", "--executor", "dask"], "dask"),
    ("bench-ray-address-without-ray", ["bench", "--ray-address", "auto"], "--executor ray"),
    ("bench-ray-address-malformed", ["bench", "--executor", "ray", "--ray-address", "not an address"], "address"),
    ("bench-results-dir", ["bench", "--results", "DIR"], "not a regular file"),
    ("bench-results-unwritable", ["bench", "--results", "UNWRITABLE/r.jsonl"], "cannot write"),
    ("bench-results-garbage", ["bench", "--results", "GARBAGE"], "not valid JSON"),
    ("bench-results-nokeys", ["bench", "--results", "NOKEYS"], "lacks"),
    ("bench-runs-dir-is-file", ["bench", "--runs-dir", "FILE"], "not a directory"),
    ("bench-backend-options-not-object", ["bench", "--backend-options", "[1]"], "JSON object"),
    ("bench-backend-options-not-json", ["bench", "--backend-options", "{x"], "JSON object"),
    ("bench-doremi-k-zero", ["bench", "--doremi-k", "0"], "--doremi-k"),
    ("bench-tracker-unknown", ["bench", "--tracker", "nope"], "nope"),
    ("bench-backend-unknown", ["bench", "--backend", "nope"], "nope"),
    ("bench-suite-unknown", ["bench", "--suite", "nope"], "--suite"),
    ("bench-max-tokens-zero", ["bench", "--max-tokens", "0"], "--max-tokens"),
    ("report-dir", ["report", "DIR"], "is a directory"),
    ("report-missing", ["report", "none.jsonl"], "no such file"),
    ("report-empty", ["report", "EMPTY"], "no episode records"),
    ("report-garbage", ["report", "GARBAGE"], "not valid JSON"),
    ("report-one-garbage-line", ["report", "GARBAGE1"], "not valid JSON"),
    ("report-nokeys", ["report", "NOKEYS"], "lacks"),
    ("report-fewkeys", ["report", "FEWKEYS"], "lacks"),
    ("report-out-is-file", ["report", "FEWKEYS", "--out", "FILE"], "not a directory"),
    ("report-out-unwritable", ["report", "FEWKEYS", "--out", "UNWRITABLE/rep"], "cannot write"),
    ("record-out-exists", ["record", "stack-in-order", "--out", "FILE"], "already exists"),
    ("record-out-unwritable", ["record", "stack-in-order", "--out", "UNWRITABLE/ep.mcap"], "cannot write"),
    ("record-out-missing", ["record", "stack-in-order"], "--out"),
    ("record-seed-negative", ["record", "stack-in-order", "--seed", "-1", "--out", "ep.mcap"], "--seed"),
    ("record-depth-encoding-unknown", ["record", "stack-in-order", "--out", "ep.mcap", "--depth-encoding", "8UC3"],
     "--depth-encoding"),
    ("monitor-bag-missing", ["monitor", "none.mcap"], "no such file"),
    ("monitor-topics-missing", ["monitor", "DIR", "--topics", "none.yaml"], "no such file"),
    ("monitor-rate-unknown", ["monitor", "DIR", "--rate", "warp"], "--rate"),
    ("monitor-hz-huge", ["monitor", "DIR", "--camera-hz", "5000"], "--camera-hz"),
    ("monitor-deadline-zero", ["monitor", "DIR", "--deadline", "0"], "--deadline"),
    ("monitor-instruction-empty", ["monitor", "DIR", "--instruction", " "], "--instruction"),
    ("monitor-objects-empty", ["monitor", "DIR", "--objects", ",,"], "--objects"),
    pytest.param("monitor-bag-garbage", ["monitor", "GARBAGE"], "cannot read bag",
                 marks=pytest.mark.skipif(importlib.util.find_spec("rosbags") is None, reason="needs the ros extra")),
    ("reproduce-results-missing", ["reproduce", "none.jsonl", "--key", "stack-p0/cam/0/0"], "no such file"),
    ("reproduce-results-dir", ["reproduce", "DIR", "--key", "stack-p0/cam/0/0"], "is a directory"),
    ("reproduce-key-malformed", ["reproduce", "FEWKEYS", "--key", "stack-p0/cam/x/0"], "--key"),
    ("reproduce-not-results", ["reproduce", "FEWKEYS", "--key", "stack-p0/cam/0/0"], "bench_start"),
    ("reproduce-runs-unwritable", ["reproduce", "FEWKEYS", "--key", "stack-p0/cam/0/0", "--runs", "UNWRITABLE/r"],
     "cannot write"),
    ("unknown-command", ["frobnicate"], "frobnicate"),
]


def _unwritable(tmp_path: Path) -> Path:
    """A directory in which nothing can be created, for root too."""
    if os.geteuid() != 0:
        d = tmp_path.parent / (tmp_path.name + "-ro")
        d.mkdir(exist_ok=True)
        d.chmod(0o555)
        return d
    return Path("/proc/self/fdinfo")  # procfs: no new entries, whoever asks


def _snapshot(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): (p.stat().st_size if p.is_file() else -1) for p in root.rglob("*")}


@pytest.fixture
def workdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "existing.txt").write_text("keep me\n")
    (tmp_path / "adir").mkdir()
    (tmp_path / "empty.jsonl").write_text("")
    (tmp_path / "garbage.jsonl").write_text("not json\n{}\n")
    (tmp_path / "garbage1.jsonl").write_text("not json\n")  # a complete line: not a torn write
    (tmp_path / "nokeys.jsonl").write_text('{"kind": "episode", "condition": "stack-p0"}\n')
    (tmp_path / "fewkeys.jsonl").write_text(EP + "\n")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _resolve(argv: list[str], root: Path) -> list[str]:
    subs = {"FILE": "existing.txt", "DIR": "adir", "EMPTY": "empty.jsonl", "GARBAGE": "garbage.jsonl",
            "GARBAGE1": "garbage1.jsonl",
            "NOKEYS": "nokeys.jsonl", "FEWKEYS": "fewkeys.jsonl"}
    unwritable = str(_unwritable(root))
    return [subs.get(a, a.replace("UNWRITABLE", unwritable)) for a in argv]


def _case(c):
    return c.values if hasattr(c, "values") else c


def _param(c):
    if hasattr(c, "values"):  # a pytest.param with marks
        return pytest.param(*c.values[1:], marks=c.marks, id=c.values[0])
    return pytest.param(*c[1:], id=c[0])


def test_the_table_is_large_and_covers_every_command() -> None:
    """Every registered command has bad inputs here (a new command must add its own)."""
    from code_as_monitor.cli.main import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert len(CASES) >= 40
    assert {_case(c)[1][0] for c in CASES} >= set(sub.choices)


@pytest.mark.parametrize(("argv", "needle"), [_param(c) for c in CASES])
def test_bad_input_is_one_line_exit_2_nothing_left(workdir: Path, capsys: pytest.CaptureFixture[str],
                                                   argv: list[str], needle: str) -> None:
    before = _snapshot(workdir)
    rc = main(_resolve(argv, workdir))
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 2, cap
    assert len(lines) == 1, lines
    assert lines[0].startswith("cam"), lines
    assert needle in lines[0], lines
    assert "Traceback" not in cap.err and cap.out == ""
    assert _snapshot(workdir) == before


def _can_mount_read_only() -> bool:
    if os.geteuid() != 0 or not shutil.which("unshare") or not sys.platform.startswith("linux"):
        return False
    probe = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c",
                            "mount --bind -o ro / /mnt 2>/dev/null && umount /mnt"], capture_output=True)
    return probe.returncode == 0


@pytest.mark.skipif(not _can_mount_read_only(), reason="needs root and mount namespaces to mount a read-only fs")
@pytest.mark.parametrize("argv", [
    ["run", "stack-in-order", "--runs", "RO/runs"],
    ["sim", "stack-in-order", "--video", "RO/v.mp4"],
    ["bench", "--results", "RO/r.jsonl"],
    ["report", "RO/r.jsonl"],
    ["record", "stack-in-order", "--out", "RO/ep.mcap"],
    ["monitor", "RO/r.jsonl", "--runs", "RO/runs"],
], ids=["run-runs", "sim-video", "bench-results", "report-default-out", "record-out", "monitor-runs"])
def test_read_only_file_system(tmp_path: Path, argv: list[str]) -> None:
    """The output flags on a real read-only mount (a private bind mount, invisible outside the test)."""
    ro = tmp_path / "ro"
    ro.mkdir()
    (ro / "r.jsonl").write_text(EP.replace("}", ', "sim_time_s": 1.0, "vlm": {"calls": 0, "total_tokens": 0}, '
                                              '"alarms": [], "gt": []}') + "\n")
    before = _snapshot(tmp_path)
    cmd = " ".join(f"'{a}'" for a in [sys.executable, "-m", "code_as_monitor.cli.main",
                                      *[a.replace("RO", str(ro)) for a in argv]])
    proc = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c",
                           f"mount --bind -o ro '{ro}' '{ro}' && exec {cmd}"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and "Read-only file system" in lines[0], lines
    assert _snapshot(tmp_path) == before
