"""Write episode videos (mp4 through imageio-ffmpeg)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from code_as_monitor.core.errors import RunError
from code_as_monitor.core.observation import View


def tile_views(views: dict[str, View]) -> np.ndarray:
    """(H, sum W, 3) uint8: the views' RGB side by side (heights padded to the tallest)."""
    imgs = [v.rgb for v in views.values()]
    h = max(i.shape[0] for i in imgs)
    imgs = [np.pad(i, ((0, h - i.shape[0]), (0, 0), (0, 0))) for i in imgs]
    return np.concatenate(imgs, axis=1)


def write_video(path: str | Path, frames: list[np.ndarray], fps: float) -> Path:
    """Write ``frames`` ((H, W, 3) uint8 each) to ``path``; RunError if it exists or there are none."""
    import imageio.v2 as imageio

    path = Path(path)
    if path.exists():
        raise RunError(f"video {str(path)!r} already exists; refusing to overwrite it")
    if not frames:
        raise RunError(f"no frames to write to {str(path)!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    h, w = frames[0].shape[:2]
    pad = ((0, h % 2), (0, w % 2), (0, 0))  # even sizes for yuv420p
    with imageio.get_writer(str(path), fps=fps, codec="libx264", macro_block_size=1, ffmpeg_log_level="error") as wr:
        for f in frames:
            wr.append_data(np.pad(f, pad))
    return path
