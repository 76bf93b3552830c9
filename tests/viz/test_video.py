"""Episode videos are real MP4 files and never overwrite an earlier run's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from code_as_monitor.core.errors import RunError
from code_as_monitor.viz.video import VideoWriter, tile


def test_writes_a_readable_mp4(tmp_path: Path) -> None:
    path = tmp_path / "ep.mp4"
    with VideoWriter(path, fps=10) as w:
        for i in range(12):
            w.write(np.full((48, 64, 3), 20 * i % 255, np.uint8))
    assert path.stat().st_size > 500
    assert path.read_bytes()[4:8] == b"ftyp"


def test_refuses_to_overwrite(tmp_path: Path) -> None:
    path = tmp_path / "ep.mp4"
    path.write_bytes(b"x")
    with pytest.raises(RunError, match="exists"):
        VideoWriter(path)


def test_tile_pads_and_makes_even_sizes() -> None:
    out = tile([np.zeros((31, 20, 3), np.uint8), np.zeros((25, 11, 3), np.uint8)])
    assert out.shape == (30, 30, 3)
