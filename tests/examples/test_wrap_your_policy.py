"""The README's example runs: a user loop around the simulator through the public Monitor API."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "wrap_your_policy.py"


def test_the_example_wraps_a_policy_and_recovers_from_a_drop(capsys) -> None:
    pytest.importorskip("pybullet")
    spec = importlib.util.spec_from_file_location("wrap_your_policy", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    # Seed 1 drops the blue block in transport (tests/recordings uses the same episode).
    assert mod.main(tracker="sim", size=(160, 120), seed=1)
    out = capsys.readouterr().out
    assert "halt: attached_blue_block" in out and "task_done" in out
