"""``--rerun``: a run saves run.rrd, which rerun's own reader opens offline with every part logged.
Skipped when the optional ``rerun`` extra is not installed."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from code_as_monitor.cli.main import main


def _alarms_on(run_dir: Path, constraint_id: str) -> int:
    """How many alarms the run's event log holds on ``constraint_id``."""
    import json

    lines = (run_dir / "events.jsonl").read_text().splitlines()
    events = [json.loads(line) for line in lines]
    return sum(1 for e in events if e.get("kind") == "alarm" and e.get("constraint_id") == constraint_id)


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
    drops = _alarms_on(run_dir, "attached_blue_block")
    assert drops >= 1, "the episode has a drop (p = 0.3)"
    assert ents["/checks/attached_blue_block/alarm"] == drops, "each drop's alarm marked on its check"


def test_rerun_without_the_extra_is_one_line_exit_2(tmp_path: Path, capsys, monkeypatch) -> None:
    monkeypatch.setitem(__import__("sys").modules, "rerun", None)  # as if rerun-sdk were not installed
    runs = tmp_path / "runs"
    assert main(["run", "stack-in-order", "--rerun", "--runs", str(runs)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'rerun' extra" in err[0]
    assert not runs.exists()


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_listening(port: int, proc, timeout_s: float = 30.0) -> None:
    import socket
    import time

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        assert proc.poll() is None, "the rerun server exited before it listened"
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise AssertionError(f"the rerun server did not listen on port {port} within {timeout_s} s")


def test_connect_streams_the_run_to_a_running_rerun_server(tmp_path: Path) -> None:
    """``--rerun connect``: rerun's own server (the ``rerun`` binary of the extra, no viewer window, saving
    what it receives) gets the same parts a saved run.rrd has."""
    import os
    import shutil
    import signal
    import subprocess
    import sys

    pytest.importorskip("rerun")
    pytest.importorskip("pybullet")
    exe = shutil.which("rerun", path=str(Path(sys.executable).parent))
    if exe is None:
        pytest.skip("the rerun extra's `rerun` binary is not next to this interpreter")
    port = _free_port()
    got = tmp_path / "received.rrd"
    env = {**os.environ, "TELEMETRY_ENABLED": "false", "HOME": str(tmp_path)}
    # its own session: the `rerun` entry point runs the viewer binary as a child, which a signal to the
    # entry point alone leaves running (seen: an orphaned server an hour after the test)
    server = subprocess.Popen([exe, "--port", str(port), "--save", str(got)], env=env, start_new_session=True,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        _wait_listening(port, server)
        runs = tmp_path / "runs"
        argv = ["run", "stack-in-order", "--seed", "1", "--p", "0.3", "--tracker", "sim", "--size", "160x120",
                "--no-video", "--quiet", "--rerun", "connect", "--rerun-url",
                f"rerun+http://127.0.0.1:{port}/proxy", "--runs", str(runs)]
        assert main(argv) == 0
        (run_dir,) = runs.iterdir()
        assert not (run_dir / "run.rrd").exists(), "connect streams; it does not save"
    finally:
        os.killpg(server.pid, signal.SIGINT)  # the whole group: the entry point and the server it started
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, signal.SIGKILL)
            server.wait()
    ents = _entities(got)
    for name in ("/views/front/image", "/world/end_effector", "/events/alarms"):
        assert ents[name] > 0, (name, sorted(ents))
    assert ents["/checks/attached_blue_block/margin"] > 5
    drops = _alarms_on(run_dir, "attached_blue_block")
    assert drops >= 1 and ents["/checks/attached_blue_block/alarm"] == drops


@pytest.mark.parametrize("url", ["bogus://", "127.0.0.1:9876", "http://127.0.0.1:9876/proxy"])
def test_a_url_rerun_cannot_use_is_one_line_exit_2_before_any_run_dir(tmp_path: Path, capsys, url: str) -> None:
    pytest.importorskip("rerun")
    runs = tmp_path / "runs"
    assert main(["run", "stack-in-order", "--rerun", "connect", "--rerun-url", url, "--runs", str(runs)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and repr(url) in err[0] and "rerun+http://" in err[0]
    assert not runs.exists()


def test_rerun_url_without_connect_is_one_line_exit_2(tmp_path: Path, capsys) -> None:
    pytest.importorskip("rerun")
    runs = tmp_path / "runs"
    argv = ["run", "stack-in-order", "--rerun", "--rerun-url", "rerun+http://127.0.0.1:9876/proxy", "--runs", str(runs)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--rerun-url applies to --rerun connect" in err[0]
    assert not runs.exists()
