"""`cam demo` (its default perception) and `cam demo --tracker sim` succeed on the demo seed and on at
least 9 of 10 other seeds (issue 16). Slow: 22 closed-loop episodes through the real CLI.

Every run is the user's command with ``--no-video --quiet`` and a fresh ``--runs`` directory. ``cam demo``
exits 0 on a failed episode too (a failure is a result, not an error), so the episode's outcome is read from
the ``summary.json`` it wrote; a non-zero exit (an error, bad input) counts as a failure as well.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("pybullet")

from code_as_monitor.cli.demo_cmd import DEMO_SEED

OTHER_SEEDS = [s for s in range(1, 12) if s != DEMO_SEED][:10]


def demo_outcome(tmp: Path, seed: int, extra: list[str]) -> str:
    """The outcome (``success``, ``failure``, ``error``, ...) of ``cam demo --seed SEED EXTRA``."""
    runs = tmp / f"runs-{seed}-{'-'.join(extra) or 'default'}"
    cmd = [sys.executable, "-m", "code_as_monitor.cli.main", "demo", "--seed", str(seed), "--no-video", "--quiet",
           "--runs", str(runs), *extra]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    summaries = sorted(runs.glob("*/summary.json"))
    if p.returncode != 0 or len(summaries) != 1:
        return f"exit {p.returncode}: {(p.stdout + p.stderr).strip().splitlines()[-1:]}"
    s = json.loads(summaries[0].read_text())
    return str(s["outcome"]) if s["outcome"] == "success" else f"{s['outcome']}: {s.get('reason')}"


@pytest.mark.slow
@pytest.mark.timeout(2 * 11 * 900)
@pytest.mark.parametrize("extra", [[], ["--tracker", "sim"]], ids=["default-perception", "oracle-tracker"])
def test_demo_succeeds_on_demo_seed_and_9_of_10_others(tmp_path: Path, extra: list[str]) -> None:
    got = demo_outcome(tmp_path, DEMO_SEED, extra)
    assert got == "success", f"demo seed {DEMO_SEED}: {got}"
    results = {s: demo_outcome(tmp_path, s, extra) for s in OTHER_SEEDS}
    failed = {s: r for s, r in results.items() if r != "success"}
    assert len(failed) <= 1, f"{len(failed)} of {len(OTHER_SEEDS)} seeds failed: {failed}"
