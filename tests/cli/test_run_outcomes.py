"""``cam run`` ends in one of four outcomes, each with its own exit code and a summary.json that
says it: success 0, failure 1, error 3 (the planner's backend failed), interrupted 130; a missing API
key is a bad configuration (exit 2) found before any run directory exists."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, HTTPServer
from pathlib import Path

import pytest

from code_as_monitor.cli.main import main

pytest.importorskip("pybullet")

FAST = ["--seed", "0", "--tracker", "sim", "--size", "160x120", "--no-video", "--quiet"]


def test_missing_api_key_is_exit_2_before_any_run_dir(tmp_path: Path, capsys, monkeypatch) -> None:
    monkeypatch.delenv("CAM_TEST_NO_SUCH_KEY", raising=False)
    runs = tmp_path / "runs"
    argv = ["run", "stack-in-order", "--backend", "openai", "--api-key-env", "CAM_TEST_NO_SUCH_KEY",
            "--runs", str(runs), *FAST]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "CAM_TEST_NO_SUCH_KEY" in err[0]
    assert not runs.exists()


class _Rejecting(BaseHTTPRequestHandler):
    """An OpenAI-compatible server that rejects every request's key (HTTP 401)."""

    def do_POST(self) -> None:
        body = json.dumps({"error": {"message": "invalid api key", "type": "invalid_request_error"}}).encode()
        self.send_response(401)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args: object) -> None:
        return None


def test_a_backend_error_is_its_own_outcome_not_a_task_failure(tmp_path: Path, capsys) -> None:
    server = HTTPServer(("127.0.0.1", 0), _Rejecting)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        runs = tmp_path / "runs"
        argv = ["run", "stack-in-order", "--backend", "openai", "--api-key-env", "none", "--model", "m",
                "--base-url", f"http://127.0.0.1:{server.server_address[1]}/v1", "--runs", str(runs), *FAST]
        assert main(argv) == 3
    finally:
        server.shutdown()
    (run_dir,) = runs.iterdir()
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["outcome"] == "error" and "rejected" in summary["error"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cam run: error:")


def test_an_interrupted_run_leaves_a_summary_saying_so(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    cmd = [sys.executable, "-m", "code_as_monitor.cli.main", "run", "stack-in-order", "--runs", str(runs),
           "--seed", "0", "--tracker", "sim", "--size", "160x120", "--no-video"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:  # wait until the episode is under way
            logs = list(runs.glob("*/events.jsonl")) if runs.exists() else []
            if logs and '"policy_start"' in logs[0].read_text():
                break
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert rc == 130
    (run_dir,) = runs.iterdir()
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["outcome"] == "interrupted" and summary["success"] is False
    assert summary["episode"]["subgoals"] is not None
    assert "interrupted" in proc.stderr.read()


def test_help_documents_the_exit_codes(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    for line in ("0  success", "1  failure", "2  bad input", "3  error", "130 interrupted"):
        assert line in out
