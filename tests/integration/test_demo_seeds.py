"""`cam demo` (its default perception) and `cam demo --tracker sim` succeed on the demo seed and on at
least 9 of 10 other seeds (issue 16). Slow: 22 closed-loop episodes through the real CLI.

Every run is the user's command with ``--no-video --quiet`` and a fresh ``--runs`` directory; success
is the CLI's exit status 0 (1 is a task failure, 2 bad input, 3 an error).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from code_as_monitor.cli.demo_cmd import DEMO_SEED

OTHER_SEEDS = [s for s in range(1, 12) if s != DEMO_SEED][:10]


def _demo(tmp: Path, seed: int, extra: list[str]) -> tuple[int, str]:
    runs = tmp / f"runs-{seed}-{'-'.join(extra) or 'default'}"
    cmd = [sys.executable, "-m", "code_as_monitor.cli.main", "demo", "--seed", str(seed), "--no-video", "--quiet",
           "--runs", str(runs), *extra]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    return p.returncode, (p.stdout + p.stderr).strip().splitlines()[-1:][0] if (p.stdout + p.stderr).strip() else ""


@pytest.mark.slow
@pytest.mark.timeout(2 * 11 * 900)
@pytest.mark.parametrize("extra", [[], ["--tracker", "sim"]], ids=["default-perception", "oracle-tracker"])
def test_demo_succeeds_on_demo_seed_and_9_of_10_others(tmp_path: Path, extra: list[str]) -> None:
    rc, last = _demo(tmp_path, DEMO_SEED, extra)
    assert rc == 0, f"demo seed {DEMO_SEED}: exit {rc}: {last}"
    results = {s: _demo(tmp_path, s, extra) for s in OTHER_SEEDS}
    failed = {s: r for s, r in results.items() if r[0] != 0}
    assert len(failed) <= 1, f"{len(failed)} of {len(OTHER_SEEDS)} seeds failed: {failed}"
