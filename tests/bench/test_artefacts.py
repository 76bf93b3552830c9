"""A run that ends early always leaves its summary, even when the video encoder was stopped mid-frame."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from code_as_monitor.bench.artefacts import RunArtefacts, finish_early
from code_as_monitor.core.errors import RunError


class _Interrupting:
    """Stands in for imageio-ffmpeg's frame generator when Ctrl-C lands inside it: that send raises, and the
    finished generator answers any later send with StopIteration."""

    def __init__(self) -> None:
        self.sends = 0
        self.done = False

    def send(self, frame: object) -> None:
        if self.done:
            raise StopIteration
        self.sends += 1
        if self.sends == 2:
            self.done = True
            raise KeyboardInterrupt

    def close(self) -> None:
        self.done = True


def _artefacts(tmp_path: Path) -> RunArtefacts:
    out = RunArtefacts(tmp_path, 10.0, None)
    gen = _Interrupting()
    out.video._gen, out.video._size = gen, (8, 8)  # started: the next sends go to the stand-in
    return out


def test_an_encoder_stopped_by_an_interrupt_still_closes_and_the_summary_is_written(tmp_path: Path) -> None:
    out = _artefacts(tmp_path)
    frame = np.zeros((8, 8, 3), np.uint8)
    out.video.write(frame)
    with pytest.raises(KeyboardInterrupt):
        out.video.write(frame)
    assert out.video.ended_early and "KeyboardInterrupt" in out.video.ended_early
    with pytest.raises(RunError, match="stopped early"):
        out.video.write(frame)  # named, not a StopIteration from a finished generator
    out.compose.tail = lambda: [frame]  # banners still held: close must not try to write them
    summary = {"outcome": "interrupted"}
    finish_early(out, None, tmp_path, summary, "interrupted", "Ctrl-C")
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert saved["outcome"] == "interrupted" and "cleanup_errors" not in saved
    events = [json.loads(x) for x in (tmp_path / "events.jsonl").read_text().splitlines()]
    assert events[-1]["kind"] == "run_stopped"


def test_a_failing_close_is_recorded_and_the_summary_still_written(tmp_path: Path) -> None:
    out = _artefacts(tmp_path)

    class _Monitor:
        def close(self) -> None:
            raise OSError("worker already gone")

    def broken_close() -> None:
        raise StopIteration

    out.close = broken_close  # type: ignore[method-assign]
    finish_early(out, _Monitor(), tmp_path, {"outcome": "error"}, "error", "backend down")
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert saved["outcome"] == "error"
    assert len(saved["cleanup_errors"]) == 2
    assert "StopIteration" in saved["cleanup_errors"][0] and "worker already gone" in saved["cleanup_errors"][1]
