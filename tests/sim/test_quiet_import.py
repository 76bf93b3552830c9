"""Importing the simulator prints nothing: pybullet's "build time" banner is swallowed."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytest.importorskip("pybullet")


def test_no_pybullet_banner_on_stdout_or_stderr() -> None:
    code = ("import code_as_monitor.sim, pybullet, sys; print('imported', 'pybullet' in sys.modules); "
            "print('after', file=sys.stderr)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "imported True\n"
    assert proc.stderr == "after\n"


def test_plain_import_does_print_it() -> None:
    """The control: without the quiet import the banner is there (so the test above can fail)."""
    proc = subprocess.run([sys.executable, "-c", "import pybullet"], capture_output=True, text=True, timeout=120)
    assert "build time" in proc.stdout + proc.stderr
