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


# ----- banners: held for 1.5 s, wrapped, naming the constraint ----------------------------------------

from code_as_monitor.core import CameraModel  # noqa: E402
from code_as_monitor.core.observation import Observation, View  # noqa: E402
from code_as_monitor.viz.video import (  # noqa: E402
    BANNER_HOLD_S,
    FrameComposer,
    banner_lines,
    draw_wrapped_banner,
)

REASON = ("the green block is 3.4 cm from the suction cup, more than the allowed 1.5 cm, so it is no longer "
          "attached and will fall before the place action ends")


def _obs(t: float) -> Observation:
    cam = CameraModel.look_at("front", [0.0, -1.0, 0.5], [0.0, 0.0, 0.0], 320, 240, 60.0)
    return Observation(t, {"front": View(np.full((240, 320, 3), 90, np.uint8), np.ones((240, 320), np.float32),
                                         cam)})


def _has_banner(frame: np.ndarray, color=(200, 30, 30)) -> bool:
    row = frame[2, :, :].astype(int)  # a row inside the top banner, above its text
    return bool((np.abs(row - np.array(color)).sum(axis=1) < 30).mean() > 0.9)


def test_a_one_frame_violation_stays_up_for_1_5_s_of_video() -> None:
    fps = 10.0
    compose = FrameComposer(fps)
    shown = []
    for i in range(40):
        t = i / fps
        banner = f"VIOLATION attached_green_block: {REASON}" if i == 5 else ""
        shown.append(_has_banner(compose(_obs(t), [], None, [], banner)))
    on = [i for i, s in enumerate(shown) if s]
    assert on == list(range(5, 5 + round(BANNER_HOLD_S * fps)))  # 15 frames = 1.5 s at 10 fps


def test_a_violation_on_the_last_frame_is_padded_to_its_full_hold() -> None:
    fps = 2.0  # the open-loop baseline's sample videos
    compose = FrameComposer(fps)
    for i in range(3):
        compose(_obs(i / fps), [], None, [], "VIOLATION c1: boom" if i == 2 else "")
    tail = compose.tail()
    assert len(tail) == round(BANNER_HOLD_S * fps) - 1 and all(_has_banner(f) for f in tail)
    assert FrameComposer(fps).tail() == []


def test_the_hold_counts_video_frames_not_sim_time() -> None:
    """Sim time may jump between written frames (re-planning); the viewer sees frames."""
    compose = FrameComposer(10.0)
    shown = [_has_banner(compose(_obs(3.0 * i), [], None, [], "VIOLATION c: x" if i == 1 else ""))
             for i in range(20)]
    assert sum(shown) == 15


def test_overlapping_banners_stack_newest_on_top() -> None:
    compose = FrameComposer()
    compose(_obs(0.0), [], None, [], "VIOLATION c1: first")
    frame = compose(_obs(0.1), [], None, [], "subgoal complete")
    assert _has_banner(frame, (40, 150, 40))  # newest on top
    col = frame[:, 1, :].astype(int)
    assert ((np.abs(col - np.array((200, 30, 30))).sum(axis=1) < 30).sum()) > 10  # the violation below it


def test_banner_text_wraps_on_words_and_names_the_constraint_first() -> None:
    text = f"VIOLATION attached_green_block: {REASON}"
    lines = banner_lines(text, 640, 10.0)
    assert lines[0] == "VIOLATION attached_green_block:"
    assert all(len(x) <= 64 for x in lines) and len(lines) >= 3
    words = REASON.split()
    assert " ".join(lines[1:]).split() == words  # every word whole, in order, nothing dropped
    many = banner_lines("VIOLATION c: " + "word " * 200, 200, 10.0)
    assert len(many) == 4 and many[-1].endswith("...")


def test_wrapped_banner_grows_with_its_text() -> None:
    img = np.zeros((240, 320, 3), np.uint8)
    _, short = draw_wrapped_banner(img, "VIOLATION c: short", (200, 30, 30))
    _, long = draw_wrapped_banner(img, f"VIOLATION c: {REASON}", (200, 30, 30))
    assert long > short > 0
