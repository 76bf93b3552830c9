"""``cam record``: a live closed-loop simulator episode written as a ROS 2 bag.

Every frame the monitor took is written (colour, depth, camera info, segmentation, TF with the
end-effector and the ground-truth object poses, joint states, whether the policy had finished), plus
the simulator's ground-truth events on ``/cam/ground_truth`` so a replay can be scored. The live
run's own run directory is written as by ``cam run`` (its alarms are what a replay should reproduce).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.core.run_io import to_json


def record_episode(cfg: ClosedLoopConfig, out: Path, run_dir: Path | None = None, depth_encoding: str = "32FC1",
                   backend: Any = None, on_event: Any = None) -> dict[str, Any]:
    """Run ``cfg`` live and record it to ``out``; returns the live run's summary (with ``bag``)."""
    from code_as_monitor.recordings.writer import BagWriter

    writer = BagWriter(out, depth_encoding=depth_encoding,
                       metadata={"source": "cam record", "task": cfg.task, "seed": cfg.seed,
                                 "task_params": cfg.task_params, "camera_hz": cfg.camera_hz})
    state: dict[str, Any] = {"env": None, "n_gt": 0}

    def on_env(env: Any) -> None:
        state["env"] = env
        writer.metadata.update(instruction=env.instruction, time_limit_s=env.task.config.time_limit)

    def flush_events() -> None:
        events = state["env"].world.events.events
        for e in events[state["n_gt"]:]:
            writer.write_event(json.loads(to_json(e)))
        state["n_gt"] = len(events)

    def on_observation(obs: Any, policy_done: bool) -> None:
        flush_events()
        writer.write_observation(obs, policy_done)

    try:
        summary = run_closed_loop(cfg, run_dir, on_event=on_event, on_env=on_env, backend=backend,
                                  on_observation=on_observation)
        for e in summary["ground_truth_events"][state["n_gt"]:]:  # the settle phase's, after the last frame
            writer.write_event(json.loads(to_json(e)))
    except BaseException:
        writer.close(complete=False)
        raise
    path = writer.close(complete=True)
    summary["bag"] = {"path": str(path), "frames": writer.frames, "depth_encoding": depth_encoding}
    return summary


__all__ = ["record_episode"]
