"""Shared fixtures of the monitor tests: two constraints, a small scene, and one sandbox per module."""

from __future__ import annotations

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

