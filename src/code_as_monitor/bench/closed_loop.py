"""One closed-loop (Code-as-Monitor) episode in the simulator, with every artefact written to a run dir.

This is where the layers meet: the simulator provides the world and the open-loop policy; the agent
(planner, painter, monitor) sees them only through ``World.observe``/``World.t`` and the policy
protocol.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.agent.loop import DEFAULT_MAX_REPLANS
from code_as_monitor.core.checks import check_count, check_positive, check_seed
from code_as_monitor.core.run_io import EventLog, write_json

log = logging.getLogger(__name__)

EventCallback = Callable[[dict[str, Any]], None]


@dataclass
class ClosedLoopConfig:
    """A closed-loop episode.

    Attributes:
        task: registered simulator task id.
        seed: episode seed (scene randomisation and disturbances).
        task_params: task config fields, e.g. ``{"p": 0.3}`` or ``{"q": 2.0}``.
        backend: VLM backend name (``kb`` offline, ``openai``, ``replay``) and its options.
        segmenter, tracker: registered perception choices and their options.
        width, height, camera_hz: camera settings (the monitor runs at ``camera_hz``).
        video: write ``episode.mp4``.
        max_replans: failed subgoals allowed.
    """

    task: str = "stack-in-order"
    seed: int = 0
    task_params: dict[str, Any] = field(default_factory=dict)
    backend: str = "kb"
    backend_options: dict[str, Any] = field(default_factory=dict)
    segmenter: str = "sim"
    segmenter_options: dict[str, Any] = field(default_factory=dict)
    tracker: str = "lk"
    tracker_options: dict[str, Any] = field(default_factory=dict)
    width: int = 320
    height: int = 240
    camera_hz: float = 10.0
    video: bool = True
    max_replans: int = DEFAULT_MAX_REPLANS

    def __post_init__(self) -> None:
        check_seed("ClosedLoopConfig", self.seed)
        check_count("ClosedLoopConfig", "width", self.width, 32)
        check_count("ClosedLoopConfig", "height", self.height, 32)
        check_positive("ClosedLoopConfig", "camera_hz", self.camera_hz)
        check_count("ClosedLoopConfig", "max_replans", self.max_replans, 0)


def check_choices(cfg: ClosedLoopConfig) -> None:
    """Raise UnknownChoiceError/ConfigError naming a bad task, backend, segmenter or tracker (and its
    options) before anything is created or run."""
    import code_as_monitor.sim.tasks  # noqa: F401  (registers the tasks)
    from code_as_monitor.perception import SegmenterConfig, TrackerConfig
    from code_as_monitor.sim.tasks.base import TaskConfig
    from code_as_monitor.vlm import VLMBackendConfig

    TaskConfig.from_name(cfg.task, **cfg.task_params)
    VLMBackendConfig.get_class(cfg.backend)
    SegmenterConfig.from_name(cfg.segmenter, **cfg.segmenter_options)
    TrackerConfig.from_name(cfg.tracker, **cfg.tracker_options)


def _settle_and_evaluate(env: Any, policy_done_reason: str) -> Any:
    """Let the world run on (the policy halted) until the task's evaluation time, then evaluate."""
    from code_as_monitor.sim.episode import SETTLE_S

    world, limit = env.world, env.task.config.time_limit
    end = min(limit, world.t + SETTLE_S) if env.task.settle_after_plan() else limit
    while world.t < end - 1e-9:
        env.policy.step()
    return env.evaluate()


def run_closed_loop(
    cfg: ClosedLoopConfig, run_dir: Path | None = None, on_event: EventCallback | None = None,
    on_env: Callable[[Any], None] | None = None,
) -> dict[str, Any]:
    """Run one Code-as-Monitor episode; returns the summary (also written to ``run_dir/summary.json``).

    ``run_dir`` (created by the caller, fresh) receives ``events.jsonl`` (agent events, flushed as
    written), ``ground_truth.jsonl`` (the simulator's disturbance/consequence log), ``episode.mp4``,
    ``prompts/`` and ``programs/``. ``on_env`` is called with the ``SimEnv`` once it exists (the
    benchmark uses it to run counterfactual rollouts from inside ``on_event``).
    """
    import cv2

    from code_as_monitor.agent.loop import Agent, AgentConfig
    from code_as_monitor.monitor.runtime import MonitorRuntime
    from code_as_monitor.painter import Painter
    from code_as_monitor.perception import (
        ElementHistory,
        SegmenterConfig,
        TrackerConfig,
        make_segmenter,
        make_tracker,
    )
    from code_as_monitor.planning.coder import MonitorCoder
    from code_as_monitor.planning.generator import ConstraintGenerator
    from code_as_monitor.sim.env import make_env
    from code_as_monitor.sim.world import WorldConfig
    from code_as_monitor.viz.video import FrameComposer, VideoWriter
    from code_as_monitor.vlm import VLMBackendConfig, make_backend

    wall0 = time.perf_counter()
    backend = make_backend(VLMBackendConfig.from_name(cfg.backend, **cfg.backend_options))
    generator = ConstraintGenerator(backend)
    coder = MonitorCoder(backend, usage=generator.usage)
    painter = Painter(make_segmenter(SegmenterConfig.from_name(cfg.segmenter, **cfg.segmenter_options)))
    tracker = make_tracker(TrackerConfig.from_name(cfg.tracker, **cfg.tracker_options))
    # Views are rendered when read: the oracle tracker reads poses, not pixels, so its frames cost no render.
    world_cfg = WorldConfig(width=cfg.width, height=cfg.height, camera_hz=cfg.camera_hz, defer_render=True)

    events = EventLog(run_dir / "events.jsonl") if run_dir is not None else None
    video = VideoWriter(run_dir / "episode.mp4", fps=cfg.camera_hz) if (run_dir is not None and cfg.video) else None

    def emit(kind: str, **fields: Any) -> None:
        ev = events.write(kind, **fields) if events is not None else {"kind": kind, **fields}
        if on_event is not None:
            on_event(ev)

    compose = FrameComposer(fps=cfg.camera_hz)  # keeps verdict banners up for 1.5 s of video

    def on_frame(obs, elements, stale, verdicts, banner) -> None:
        if video is not None:
            video.write(compose(obs, elements, stale, verdicts, banner))

    def on_prompt(index: int, subgoal: Any, images: dict[str, np.ndarray], source: str) -> None:
        if run_dir is None:
            return
        (run_dir / "prompts").mkdir(exist_ok=True)
        (run_dir / "programs").mkdir(exist_ok=True)
        for view, img in images.items():
            cv2.imwrite(str(run_dir / "prompts" / f"subgoal{index:02d}_{view}.png"), img[:, :, ::-1])
        header = f"# subgoal {index}: {subgoal.text}\n"
        (run_dir / "programs" / f"subgoal{index:02d}.py").write_text(header + source, encoding="utf-8")

    runtime = MonitorRuntime()
    try:
        with make_env(cfg.task, seed=cfg.seed, world_config=world_cfg, **cfg.task_params) as env:
            if run_dir is not None:
                env.world.events.open(run_dir / "ground_truth.jsonl")
            if on_env is not None:
                on_env(env)
            agent = Agent(
                generator, coder, painter, tracker, runtime, ElementHistory,
                AgentConfig(frame_hz=cfg.camera_hz, max_replans=cfg.max_replans,
                            time_limit_s=env.task.config.time_limit),
                on_event=emit, on_frame=on_frame, on_prompt=on_prompt,
            )
            episode = agent.run(env.instruction, env.world, env.policy)
            result = _settle_and_evaluate(env, episode.stop_reason)
            gt_events = list(env.world.events.events)
            env.world.events.close()
            t_end = env.world.t
    finally:
        runtime.close()
        if video is not None:
            for frame in compose.tail():
                video.write(frame)
            video.close()
    summary: dict[str, Any] = {
        "method": "cam",
        "config": asdict(cfg),
        "task": cfg.task,
        "seed": cfg.seed,
        "success": bool(result.success),
        "reason": result.reason,
        "sim_time_s": round(float(episode.t_end), 3),
        "sim_time_end_s": round(float(t_end), 3),
        "wall_time_s": round(time.perf_counter() - wall0, 2),
        "episode": episode.to_dict(),
        "vlm": generator.usage.to_dict(),
        "ground_truth_events": gt_events,
        "task_info": result.info,
    }
    emit("outcome", success=summary["success"], reason=result.reason, sim_time_s=summary["sim_time_s"],
         vlm_calls=generator.usage.calls, vlm=generator.usage.episode())
    if events is not None:
        events.close()
    if run_dir is not None:
        write_json(run_dir / "summary.json", summary)
    return summary
