"""``cam monitor``: replay a recorded RGB-D bag through planner, painter, tracker and monitor.

The recorded robot cannot be halted: every decision is logged (``events.jsonl``), drawn on the video
and summarised, and the replay goes on with the recording. When the bag carries the policy's state
(a ``cam record`` bag does) the monitor also learns when each action finished; a bag without it ends
subgoals only on violations and on upon checks that hold. ``rate``: ``max`` (as fast as it goes) or
``realtime`` (frames handed over at their recorded pace).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from code_as_monitor.bench.artefacts import RunArtefacts, finish_early
from code_as_monitor.bench.closed_loop import early_end
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.run_io import write_json

RATES = ("max", "realtime")


def replay_bag(source: Any, instruction: str, config: Any, run_dir: Path | None = None, rate: str = "max",
               video: bool = True, backend: Any = None, on_event: Any = None,
               frame_hooks: list[Any] | None = None) -> dict[str, Any]:
    """Replay ``source`` (a :class:`~code_as_monitor.recordings.reader.BagSource`) through a monitor built
    from ``config`` (:class:`~code_as_monitor.agent.config.MonitorConfig`); returns the summary (also
    ``run_dir/summary.json``). An exception still writes the summary (outcome ``error`` /
    ``interrupted``) and is re-raised."""
    from code_as_monitor.agent.decision import DecisionKind
    from code_as_monitor.agent.monitor import build_monitor

    if rate not in RATES:
        raise ConfigError(f"rate must be one of {', '.join(RATES)}, got {rate!r}")
    out = RunArtefacts(run_dir, config.frame_hz if video else None, on_event)
    out.frame_hooks.extend(frame_hooks or [])
    summary: dict[str, Any] = {"method": "cam", "source": str(source.path), "instruction": instruction,
                               "config": {k: getattr(config, k) for k in config.__dataclass_fields__}, "rate": rate}
    monitor = None
    counts = {"judged": 0, "not_due": 0, "after_end": 0}
    decisions: list[dict[str, Any]] = []
    wall0 = time.perf_counter()
    try:
        monitor = build_monitor(config, on_event=out.emit, on_frame=out.on_frame, on_prompt=out.on_prompt,
                                backend=backend)
        monitor.start(instruction)
        t_last = 0.0
        for obs, done in source:
            t_last = obs.t
            if monitor.finished:
                counts["after_end"] += 1
                continue
            if rate == "realtime":
                time.sleep(max(0.0, wall0 + obs.t - time.perf_counter()))
            if not monitor.frame_due(obs.t, done):
                counts["not_due"] += 1
                continue
            counts["judged"] += 1
            d = monitor.step(obs, policy_done=done)
            if d.kind is not DecisionKind.CONTINUE:
                decisions.append(d.to_dict())
        if not monitor.finished:
            decisions.append(monitor.stop("the recording ended", t_last).to_dict())
    except BaseException as exc:
        outcome, reason = early_end(exc)
        summary.update(outcome=outcome, reason=reason, error=reason, wall_time_s=round(time.perf_counter() - wall0, 3))
        if monitor is not None:
            summary.update(episode=monitor.episode.to_dict(), vlm=monitor.usage.to_dict())
        finish_early(out, monitor, run_dir, summary, outcome, reason)
        raise
    monitor.close()
    wall = time.perf_counter() - wall0
    ep = monitor.episode
    summary.update({
        "outcome": "error" if ep.error is not None else "completed",
        "reason": ep.stop_reason,
        "error": f"planner failed: {ep.error}" if ep.error is not None else None,
        "duration_s": round(source.duration_s, 3),
        "wall_time_s": round(wall, 3),
        "replay_realtime_factor": round(source.duration_s / wall, 3) if wall > 0 else None,
        "frames": {**source.stats.to_dict(), **counts},
        "episode": ep.to_dict(),
        "decisions": decisions,
        "vlm": monitor.usage.to_dict(),
        "ground_truth_events": list(source.ground_truth),
    })
    out.emit("outcome", outcome=summary["outcome"], reason=ep.stop_reason, alarms=len(ep.alarms),
             frames=summary["frames"])
    out.close()
    if run_dir is not None:
        write_json(run_dir / "summary.json", summary)
    return summary


__all__ = ["RATES", "replay_bag"]
