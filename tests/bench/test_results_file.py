"""Results files: one writer at a time, code versions on every record, stale records re-run on resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from code_as_monitor.bench.executors import LocalExecutorConfig
from code_as_monitor.bench.protocol import BenchSpec
from code_as_monitor.bench.results_file import ResultsLock, code_version, record_versions, src_hash, versions_of
from code_as_monitor.bench.runner import episode_records, read_results, run_bench
from code_as_monitor.cli.main import main
from code_as_monitor.core.errors import RunError

HOLD = """
import sys, time
from code_as_monitor.bench.results_file import ResultsLock
with ResultsLock(sys.argv[1]):
    print("locked", flush=True)
    time.sleep(120)
"""


def _holder(path: Path) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "locked"
    return proc


def test_a_second_writer_gets_a_clear_error_and_a_killed_holder_frees_the_file(tmp_path: Path, capsys) -> None:
    res = tmp_path / "r.jsonl"
    holder = _holder(res)
    try:
        with pytest.raises(RunError, match="being written by another cam bench"):
            ResultsLock(res).acquire()
        rc = main(["bench", "--methods", "open-loop", "--conditions", "stack-p0", "--seeds", "1", "--episodes", "1",
                   "--workers", "1", "--no-videos", "--results", str(res)])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and "being written by another cam bench" in err[0]
        assert res.read_text() == ""  # the refused writer wrote nothing
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(10)
    with ResultsLock(res):  # the kernel dropped the dead holder's lock
        pass


def test_the_lock_excludes_within_one_process_too(tmp_path: Path) -> None:
    res = tmp_path / "r.jsonl"
    with ResultsLock(res), pytest.raises(RunError):
        ResultsLock(res).acquire()
    with ResultsLock(res):
        pass


def test_src_hash_follows_file_contents_not_history(tmp_path: Path) -> None:
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "__pycache__").mkdir()
    (tmp_path / "__pycache__" / "a.cpython.pyc").write_bytes(b"junk")
    h1 = src_hash.__wrapped__(tmp_path)
    (tmp_path / "__pycache__" / "a.cpython.pyc").write_bytes(b"other junk")
    assert src_hash.__wrapped__(tmp_path) == h1  # byte-code caches do not count
    (tmp_path / "a.py").write_text("x = 2\n")
    assert src_hash.__wrapped__(tmp_path) != h1
    assert code_version().startswith("0.") and "+src." in code_version()


def test_legacy_records_take_their_session_version() -> None:
    lines = [{"kind": "bench_start", "code": "1f0720e"}, {"kind": "episode", "x": 1},
             {"kind": "bench_start", "code_version": "0.1.0+src.abc"}, {"kind": "episode", "x": 2, "code": "v2"},
             {"kind": "episode", "x": 3}]
    codes = [r.get("code") for r in record_versions(lines) if r["kind"] == "episode"]
    assert codes == ["1f0720e", "v2", "0.1.0+src.abc"]
    assert versions_of([{"code": "a"}, {"code": "b"}, {"code": "b"}, {}]) == {"b": 2, "a": 1, "unknown": 1}


def test_resume_reruns_records_of_other_code_unless_keep_stale(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    res = tmp_path / "r.jsonl"
    spec = BenchSpec(methods=["open-loop"], conditions=["stack-p0"], seeds=1, episodes=1)
    assert run_bench(spec, res, LocalExecutorConfig(workers=1))["ran"] == 1
    lines = [json.loads(x) for x in res.read_text().splitlines()]
    (rec,) = [r for r in lines if r["kind"] == "episode"]
    start = next(r for r in lines if r["kind"] == "bench_start")
    assert rec["code"] == code_version() == start["code_version"] and start["pid"] == os.getpid()
    # Same code: nothing to do.
    assert run_bench(spec, res, LocalExecutorConfig(workers=1))["ran"] == 0
    # Pretend the record was made by other code.
    res.write_text("\n".join(json.dumps({**r, "code": "0.0.1+src.old"} if r["kind"] == "episode" else r)
                             for r in lines) + "\n")
    kept = run_bench(spec, res, LocalExecutorConfig(workers=1), keep_stale=True)
    assert kept["ran"] == 0 and kept["stale"] == 1
    again = run_bench(spec, res, LocalExecutorConfig(workers=1))
    assert again["ran"] == 1 and again["stale"] == 1
    (latest,) = episode_records(read_results(res))
    assert latest["code"] == code_version()


def test_report_names_the_versions_it_mixes(tmp_path: Path, capsys) -> None:
    res = tmp_path / "r.jsonl"
    base = {"kind": "episode", "condition": "stack-p0", "method": "cam", "success": True, "sim_time_s": 9.0,
            "vlm": {"calls": 1, "total_tokens": 10}, "alarms": [], "gt": [], "wall_time_s": 1.0}
    recs = [{**base, "seed": 0, "episode": e, "code": "0.1.0+src.aaa" if e < 2 else "0.1.0+src.bbb"}
            for e in range(3)]
    res.write_text("\n".join(json.dumps(r) for r in recs) + "\n")
    assert main(["report", str(res), "--print"]) == 0
    out = capsys.readouterr().out
    assert "Mixed code versions" in out and "`0.1.0+src.aaa`: 2 record(s)" in out and "src.bbb`: 1" in out
    res.write_text("\n".join(json.dumps({**r, "code": "0.1.0+src.aaa"}) for r in recs) + "\n")
    assert main(["report", str(res), "--print"]) == 0
    out = capsys.readouterr().out
    assert "Mixed" not in out and "Code version of every record: `0.1.0+src.aaa`: 3 record(s)" in out



def test_a_session_that_fails_before_its_first_line_leaves_no_file(tmp_path: Path) -> None:
    res = tmp_path / "new" / "dirs" / "r.jsonl"
    with pytest.raises(RuntimeError), ResultsLock(res):
        assert res.exists()
        raise RuntimeError("the executor could not start")
    assert not (tmp_path / "new").exists()
    res.parent.mkdir(parents=True)
    res.write_text("")  # an existing (empty) file is the user's: kept
    with ResultsLock(res):
        pass
    assert res.exists()
