"""The run directory's writers shared by live runs and bag replays: the event log, the video, the
visual prompts and the generated programs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.run_io import EventLog

EventCallback = Callable[[dict[str, Any]], None]


class RunArtefacts:
    """The run directory's writers: events, video, prompts and programs (all optional without a dir)."""

    def __init__(self, run_dir: Path | None, video_hz: float | None, on_event: EventCallback | None) -> None:
        from code_as_monitor.viz.video import FrameComposer, VideoWriter

        self.run_dir = run_dir
        self.events = EventLog(run_dir / "events.jsonl") if run_dir is not None else None
        self.video = VideoWriter(run_dir / "episode.mp4", fps=video_hz) if (run_dir and video_hz) else None
        self.compose = FrameComposer(fps=video_hz or 10.0)  # keeps verdict banners up for 1.5 s of video
        self.on_event = on_event
        self.frame_hooks: list[Callable[..., None]] = []

    def emit(self, kind: str, **fields: Any) -> None:
        ev = self.events.write(kind, **fields) if self.events is not None else {"kind": kind, **fields}
        if self.on_event is not None:
            self.on_event(ev)

    def on_frame(self, obs: Any, elements: Any, stale: Any, verdicts: Any, banner: str) -> None:
        if self.video is not None:
            self.video.write(self.compose(obs, elements, stale, verdicts, banner))
        for hook in self.frame_hooks:
            hook(obs, elements, stale, verdicts, banner)

    def on_prompt(self, index: int, subgoal: Any, images: dict[str, np.ndarray], source: str) -> None:
        if self.run_dir is None:
            return
        import cv2

        (self.run_dir / "prompts").mkdir(exist_ok=True)
        (self.run_dir / "programs").mkdir(exist_ok=True)
        for view, img in images.items():
            cv2.imwrite(str(self.run_dir / "prompts" / f"subgoal{index:02d}_{view}.png"), img[:, :, ::-1])
        header = f"# subgoal {index}: {subgoal.text}\n"
        (self.run_dir / "programs" / f"subgoal{index:02d}.py").write_text(header + source, encoding="utf-8")

    def close(self) -> None:
        """Finish the video (its held banners) and close the event log, which is closed even when the
        video cannot be finished (an encoder stopped by an interrupt)."""
        try:
            if self.video is not None:
                if self.video.ended_early is None:
                    for frame in self.compose.tail():
                        self.video.write(frame)
                self.video.close()
        finally:
            if self.events is not None:
                self.events.close()


def finish_early(out: RunArtefacts, monitor: Any, run_dir: Path | None, summary: dict[str, Any], outcome: str,
                 reason: str) -> None:
    """After a run ended early (interrupt, backend error): log ``run_stopped``, close the writers and the
    monitor, and always write ``summary.json``. A step that fails (an encoder stopped mid-frame by the
    interrupt) is recorded in ``summary["cleanup_errors"]`` and never masks the exception that ended the run,
    nor keeps the summary from being written."""
    from code_as_monitor.core.run_io import write_json

    problems: list[str] = []
    steps = [("log run_stopped", lambda: out.emit("run_stopped", outcome=outcome, reason=reason)),
             ("close the video and the event log", out.close)]
    if monitor is not None:
        steps.append(("close the monitor", monitor.close))
    try:
        for what, step in steps:
            try:
                step()
            except Exception as exc:
                problems.append(f"could not {what}: {type(exc).__name__}: {exc}"[:300])
    finally:
        if problems:
            summary["cleanup_errors"] = problems
        if run_dir is not None:
            write_json(run_dir / "summary.json", summary)


__all__ = ["RunArtefacts", "finish_early"]
