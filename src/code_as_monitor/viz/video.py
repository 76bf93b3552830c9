"""Episode videos: every monitored frame, views side by side, elements and verdict banners drawn.

Frames are streamed to an H.264 MP4 through imageio-ffmpeg (which ships its own ffmpeg binary),
so memory stays flat however long the episode is.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from code_as_monitor.core.constraints import Verdict
from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import RunError
from code_as_monitor.core.observation import Observation
from code_as_monitor.painter.draw import draw_banner, draw_caption, draw_elements


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
        color = (40, 150, 40) if banner.startswith("subgoal complete") else (200, 30, 30)
        frame = draw_banner(frame, banner, color)
    elif subtitle:
        frame = draw_banner(frame, subtitle, (40, 40, 90))
    return frame


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

    def write(self, frame: np.ndarray) -> None:
        """Append one (H, W, 3) uint8 frame; later frames are padded/cropped to the first one's size."""
        import imageio_ffmpeg

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
        self._gen.send(np.ascontiguousarray(frame, dtype=np.uint8))
        self.frames += 1

    def close(self) -> None:
        if self._gen is not None:
            self._gen.close()
            self._gen = None

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
