"""Shared fixtures of the monitor tests: two constraints, a small scene, and one sandbox per module."""

from __future__ import annotations

import time

import numpy as np
import pytest

from code_as_monitor.core.constraints import Constraint, Phase
from code_as_monitor.monitor.sandbox import Sandbox


@pytest.fixture
def constraints() -> list[Constraint]:
    return [Constraint("a", "block stays on the tip", Phase.DURING), Constraint("b", "block lifted", Phase.UPON)]


@pytest.fixture
def scene() -> dict[int, np.ndarray]:
    """Element 0: the tip (point); element 1: the block's top (a 4-point surface) 2 cm below, 0.2 m up."""
    tip = np.array([[0.0, 0.0, 0.22]])
    top = np.array([[-0.02, -0.02, 0.2], [0.02, -0.02, 0.2], [0.02, 0.02, 0.2], [-0.02, 0.02, 0.2]])
    return {0: tip, 1: top}


@pytest.fixture(scope="module")
def sandbox():
    with Sandbox(deadline_s=0.15) as sb:
        yield sb


def process_state(pid: int) -> str | None:
    """The state letter of a process (R, S, Z ...) or None when it no longer exists."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return None


def wait_gone(pid: int, timeout: float = 5.0) -> bool:
    """True once ``pid`` has exited (gone or a zombie) within ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if process_state(pid) in (None, "Z", "X"):
            return True
        time.sleep(0.01)
    return False
