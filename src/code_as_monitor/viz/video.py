"""Episode videos: every monitored frame, views side by side, elements and verdict banners drawn.

Frames are streamed to an H.264 MP4 through imageio-ffmpeg (which ships its own ffmpeg binary),
so memory stays flat however long the episode is.

Banners: a verdict (``VIOLATION <constraint id>: <reason>``, ``subgoal complete``) happens on one
monitored frame, a tenth of a second of video. :class:`FrameComposer` keeps every banner up for
``hold_s`` (1.5 s) of video (counted in frames), stacks banners that overlap in time (newest on top), wraps their text
over as many lines as it needs (a violation's first line names the constraint), and at the end of an
episode pads the video with the last frame so that the last banner is shown for its whole hold too.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Verdict
from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import RunError
from code_as_monitor.core.observation import Observation
from code_as_monitor.painter.draw import draw_caption, draw_elements

BANNER_HOLD_S = 1.5
"""Seconds of video a banner stays up."""
VIOLATION_COLOR = (200, 30, 30)
COMPLETE_COLOR = (40, 150, 40)
SUBTITLE_COLOR = (40, 40, 90)
MAX_BANNER_LINES = 4


def banner_lines(text: str, width_px: int, char_px: float) -> list[str]:
    """Split ``text`` into lines of whole words that fit ``width_px`` at ``char_px`` per character.

    ``VIOLATION <id>: <reason>`` puts the constraint on a line of its own. At most
    ``MAX_BANNER_LINES`` lines; a longer text ends in an ellipsis. A word longer than a line is cut.
    """
    import textwrap

    per_line = max(10, int(width_px / char_px))
    head, sep, rest = text.partition(": ")
    paragraphs = [head + ":", rest] if text.startswith("VIOLATION ") and sep else [text]
    lines: list[str] = []
    for para in paragraphs:
        lines += textwrap.wrap(para, per_line, break_long_words=True, break_on_hyphens=False) or [""]
    if len(lines) > MAX_BANNER_LINES:
        lines = lines[:MAX_BANNER_LINES]
        lines[-1] = lines[-1][: per_line - 3].rstrip() + "..."
    return lines


def draw_wrapped_banner(rgb: np.ndarray, text: str, color: tuple[int, int, int],
                        top: int = 0) -> tuple[np.ndarray, int]:
    """Draw a full-width banner with ``text`` wrapped over lines, starting at row ``top``.

    Returns the image (a copy) and the row just below the banner.
    """
    import cv2

    img = np.ascontiguousarray(rgb.copy())
    s = max(0.5, min(img.shape[0], img.shape[1]) / 480.0)
    font, fs, th = cv2.FONT_HERSHEY_SIMPLEX, 0.5 * s, 1
    (cw, ch), base = cv2.getTextSize("abcdefghijklmnopqrstuvwxyz", font, fs, th)
    lines = banner_lines(text, img.shape[1] - 12, cw / 26.0)
    line_h = ch + base + round(6 * s)
    bottom = min(img.shape[0], top + line_h * len(lines) + round(6 * s))
    cv2.rectangle(img, (0, top), (img.shape[1], bottom), color, -1)
    for i, line in enumerate(lines):
        y = top + round(4 * s) + ch + i * line_h
        cv2.putText(img, line, (6, y), font, fs, (255, 255, 255), th, cv2.LINE_AA)
    return img, bottom


def tile(images: list[np.ndarray]) -> np.ndarray:
    """Place (H_i, W_i, 3) uint8 images side by side, padding heights to the tallest."""
    h = max(im.shape[0] for im in images)
    padded = [np.pad(im, ((0, h - im.shape[0]), (0, 0), (0, 0))) for im in images]
    out = np.concatenate(padded, axis=1)
    # H.264 wants even sizes.
    return np.ascontiguousarray(out[: out.shape[0] // 2 * 2, : out.shape[1] // 2 * 2])


def compose_frame(
    obs: Observation,
    elements: list[Element],
    stale: dict[int, np.ndarray] | None,
    verdicts: list[Verdict],
    banner: str,
    subtitle: str = "",
) -> np.ndarray:
    """One video frame: each view with the elements drawn, a caption, and a banner when ``banner`` is set."""
    views = []
    for name, v in obs.views.items():
        img = draw_elements(v.rgb, v.camera, elements, stale)
        img = draw_caption(img, f"{name}  t={obs.t:5.2f}s")
        views.append(img)
    frame = tile(views)
    if banner:
        frame, _ = draw_wrapped_banner(frame, banner, _banner_color(banner))
    elif subtitle:
        frame, _ = draw_wrapped_banner(frame, subtitle, SUBTITLE_COLOR)
    return frame


def _banner_color(text: str) -> tuple[int, int, int]:
    return COMPLETE_COLOR if text.startswith("subgoal complete") else VIOLATION_COLOR


class FrameComposer:
    """Composes frames like :func:`compose_frame`, keeping each banner up for ``hold_s`` of video.

    The hold is counted in written frames (``ceil(hold_s * fps)``), not in sim time: the monitor does
    not write a frame for every tick (re-planning, settling), and what a viewer sees is video time.
    Call it with the same arguments as :func:`compose_frame` for every frame written, in order; then
    :meth:`tail` gives the frames to append at the end so that the last banners get their full hold.
    """

    def __init__(self, fps: float = 10.0, hold_s: float = BANNER_HOLD_S) -> None:
        self.hold_frames = max(1, math.ceil(hold_s * fps - 1e-9))
        self.active: list[list[Any]] = []  # [frames left, text], oldest first
        self._last: np.ndarray | None = None  # the last frame without banners

    def __call__(self, obs: Observation, elements: list[Element], stale: dict[int, np.ndarray] | None,
                 verdicts: list[Verdict], banner: str, subtitle: str = "") -> np.ndarray:
        self.active = [a for a in self.active if a[0] > 0 and a[1] != banner]
        if banner:
            self.active.append([self.hold_frames, banner])
        plain = compose_frame(obs, elements, stale, verdicts, "", "" if self.active else subtitle)
        self._last = plain
        return self._draw(plain)

    def _draw(self, plain: np.ndarray) -> np.ndarray:
        frame, top = plain, 0
        for a in reversed(self.active):  # newest on top
            a[0] -= 1
            if top < frame.shape[0] // 2:
                frame, top = draw_wrapped_banner(frame, a[1], _banner_color(a[1]), top)
        return frame

    def tail(self) -> list[np.ndarray]:
        """Frames (the last picture, banners still up) that complete the hold of the last banners."""
        out: list[np.ndarray] = []
        if self._last is None:
            return out
        while True:
            self.active = [a for a in self.active if a[0] > 0]
            if not self.active:
                return out
            out.append(self._draw(self._last))


class VideoWriter:
    """Streams RGB frames to an MP4 file.

    Args:
        path: output ``.mp4``; must not exist (runs never overwrite each other).
        fps: frames per second of the video (use the monitoring rate for real-time playback).
    """

    def __init__(self, path: str | os.PathLike[str], fps: float = 10.0) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise RunError(f"video {self.path} exists already; refusing to overwrite it")
        self.fps = fps
        self._gen = None
        self._size: tuple[int, int] | None = None
        self.frames = 0
        self.ended_early: str | None = None  # why the encoder stopped before close() (an interrupt mid-frame)

    def write(self, frame: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 frame; later frames are padded/cropped to the first one's size."""
        import imageio_ffmpeg

        if self.ended_early is not None:
            raise RunError(f"video {self.path}: the encoder stopped early ({self.ended_early}); frame not written")
        if self._gen is None:
            h, w = frame.shape[:2]
            self._size = (w, h)
            self._gen = imageio_ffmpeg.write_frames(
                str(self.path), (w, h), fps=self.fps, codec="libx264", pix_fmt_out="yuv420p",
                macro_block_size=2, ffmpeg_log_level="error", output_params=["-crf", "26"],
            )
            self._gen.send(None)
        w, h = self._size  # type: ignore[misc]
        if frame.shape[0] != h or frame.shape[1] != w:
            fixed = np.zeros((h, w, 3), np.uint8)
            hh, ww = min(h, frame.shape[0]), min(w, frame.shape[1])
            fixed[:hh, :ww] = frame[:hh, :ww]
            frame = fixed
        try:
            self._gen.send(np.ascontiguousarray(frame, dtype=np.uint8))
        except BaseException as exc:  # the encoder's generator is finished: later sends would be StopIteration
            self.ended_early = f"{type(exc).__name__} while writing frame {self.frames + 1}"
            self._gen = None
            raise
        self.frames += 1

    def close(self) -> None:
        if self._gen is not None:
            self._gen.close()
            self._gen = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
