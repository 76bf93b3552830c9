"""A recorded simulator episode shared by the recording tests (one live run per test session)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("rosbags")

# A drop at 5.9 s is caught by the 'attached' check; the re-plan picks the block up again (oracle
# `sim` tracker to keep the live run short; the LK replay is a slow test). A 1 s sandbox deadline in
# both runs so that a loaded test machine cannot turn a frame into a program fault in one of them.
EPISODE = {"task": "stack-in-order", "seed": 1, "task_params": {"p": 0.3}, "tracker": "sim", "width": 160,
           "height": 120, "video": False, "deadline_s": 1.0}


@pytest.fixture(scope="session")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    """(bag path, the live run's summary)."""
    pytest.importorskip("pybullet")
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig
    from code_as_monitor.bench.record import record_episode

    d = tmp_path_factory.mktemp("recorded")
    (d / "live").mkdir()
    summary = record_episode(ClosedLoopConfig(**EPISODE), d / "ep.mcap", d / "live")
    return d / "ep.mcap", summary
