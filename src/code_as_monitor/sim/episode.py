"""Run one open-loop episode: the task's default plan through the (disturbed) scripted policy."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from code_as_monitor.core.errors import RunError
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig

SETTLE_S = 1.0  # sim seconds to wait after the plan before evaluating a plan-terminated task


@dataclass
class EpisodeResult:
    """``t``: sim seconds at evaluation; ``events``: the ground-truth event log."""

    task: str
    seed: int
    success: bool
    reason: str
    t: float
    events: list[dict[str, Any]] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    n_frames: int = 0

    def to_dict(self) -> dict[str, Any]:
        return {"task": self.task, "seed": self.seed, "success": self.success, "reason": self.reason, "t": self.t,
                "n_frames": self.n_frames, "info": self.info, "events": self.events}


def run_open_loop(name: str, seed: int = 0, world_config: WorldConfig | None = None, video: str | Path | None = None,
                  events_path: str | Path | None = None, **task_config: Any) -> EpisodeResult:
    """Run task ``name``'s default plan open loop until it ends (plus ``SETTLE_S``) or the time limit.

    ``video``: mp4 path (frames rendered at ``world_config.camera_hz``); ``events_path``: JSONL event log.
    Neither may exist already. Rendering happens only when a video is asked for.
    """
    for p in (video, events_path):
        if p is not None and Path(p).exists():
            raise RunError(f"output {str(p)!r} already exists; refusing to overwrite it")
    frames = []
    with make_env(name, seed=seed, world_config=world_config, **task_config) as env:
        world, policy, limit = env.world, env.policy, env.task.config.time_limit
        if events_path is not None:
            Path(events_path).parent.mkdir(parents=True, exist_ok=True)
            world.events.open(events_path)

        def tick() -> None:
            policy.step()
            if video is not None and world.frame_due():
                from code_as_monitor.sim.video import tile_views

                frames.append(tile_views(world.observe().views))

        for action in env.plan:
            policy.start(action)
            while not policy.done and world.t < limit - 1e-9:
                tick()
        end = min(limit, world.t + SETTLE_S) if env.task.settle_after_plan() else limit
        while world.t < end - 1e-9:
            tick()
        res = env.evaluate()
        out = EpisodeResult(name, seed, res.success, res.reason, world.t, list(world.events.events), res.info,
                            len(frames))
        world.events.close()
    if video is not None:
        from code_as_monitor.sim.video import write_video

        cfg = world_config or WorldConfig()
        write_video(video, frames, cfg.camera_hz)
    return out
