"""One closed-loop (Code-as-Monitor) episode in the simulator, with every artefact written to a run dir.

This is where the layers meet: the simulator provides the world and the open-loop policy; the
streaming :class:`~code_as_monitor.agent.monitor.Monitor` (planner, painter, monitor) sees them only
through observations and the policy protocol, driven by :func:`~code_as_monitor.agent.drive.drive`
exactly as a user's robot loop would drive it.

A run that ends early still leaves ``summary.json`` saying how: ``outcome`` is ``success`` or
``failure`` (the task's success check decided), ``error`` (the planner's backend failed, or an
exception stopped the run: ``error`` names it) or ``interrupted`` (Ctrl-C / SIGTERM).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from code_as_monitor.agent.ablations import ablation_fields
from code_as_monitor.agent.records import DEFAULT_MAX_REPLANS
from code_as_monitor.bench.artefacts import RunArtefacts, finish_early
from code_as_monitor.core.checks import (
    DEADLINE_S_RANGE,
    IMAGE_SIDE_RANGE,
    RATE_HZ_RANGE,
    SIM_CONTROL_HZ,
    check_count,
    check_fields,
    check_range,
    check_seed,
)
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.run_io import write_json

log = logging.getLogger(__name__)

EventCallback = Callable[[dict[str, Any]], None]
OUTCOMES = ("success", "failure", "error", "interrupted")


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
        deadline_s: the sandbox's per-frame deadline (see ``MonitorConfig.deadline_s``).
        allow_unconfined: the explicit opt-out of the sandbox's kernel confinement (see
            ``MonitorConfig.allow_unconfined``).
        ablation: a named ablation setting of the monitor (:mod:`code_as_monitor.agent.ablations`: ``full``,
            ``mv-off``, ``cs-off``, ``cp-off``, ``reactive-only``, ``proactive-only``).
        cameras: a named camera set (:data:`code_as_monitor.sim.cameras.CAMERA_SETS`): ``task`` the task's own views,
            or ``front-top``, ``front``, ``shoulders``, ``rlbench`` for every task (to see what other views do), or
            the path of a camera file (``*.json``, :mod:`code_as_monitor.sim.camera_file`): the user's own views.
        robot_visual: how the cameras draw the arm: ``decimated`` (its detailed meshes with a fifth of their
            triangles, the default), ``mesh`` (the detailed meshes) or ``hull`` (its collision meshes); the same
            physics (see :func:`code_as_monitor.sim.robot.panda_urdf`).
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
    deadline_s: float = 0.020
    allow_unconfined: bool = False
    ablation: str = "full"
    cameras: str = "task"
    robot_visual: str = "decimated"  # sim.robot.DEFAULT_ROBOT_VISUAL

    def __post_init__(self) -> None:
        from code_as_monitor.sim.robot import check_robot_visual

        name = "ClosedLoopConfig"
        check_fields(name, type(self), {f.name: getattr(self, f.name) for f in dataclasses.fields(self)})
        check_seed(name, self.seed)
        for side in ("width", "height"):
            check_range(name, side, getattr(self, side), *IMAGE_SIDE_RANGE, integer=True)
        check_range(name, "camera_hz", self.camera_hz, RATE_HZ_RANGE[0], SIM_CONTROL_HZ)
        check_count(name, "max_replans", self.max_replans, 0)
        check_range(name, "deadline_s", self.deadline_s, *DEADLINE_S_RANGE)
        for f in ("task_params", "backend_options", "segmenter_options", "tracker_options"):
            if not isinstance(getattr(self, f), dict):
                raise ConfigError(f"{name}.{f} must be a dict, got {getattr(self, f)!r}")
        ablation_fields(self.ablation)
        if not isinstance(self.cameras, str) or not self.cameras:
            raise ConfigError(f"{name}.cameras must be the name of a camera set or a camera file (.json), "
                              f"got {self.cameras!r}")
        check_robot_visual(name, self.robot_visual)

    def monitor_config(self, time_limit_s: float | None = None) -> Any:
        """The :class:`~code_as_monitor.agent.config.MonitorConfig` of this episode's monitor."""
        from code_as_monitor.agent.config import MonitorConfig

        return MonitorConfig(
            backend=self.backend, backend_options=dict(self.backend_options), segmenter=self.segmenter,
            segmenter_options=dict(self.segmenter_options), tracker=self.tracker,
            tracker_options=dict(self.tracker_options), frame_hz=self.camera_hz, max_replans=self.max_replans,
            time_limit_s=time_limit_s, deadline_s=self.deadline_s, allow_unconfined=self.allow_unconfined,
            **ablation_fields(self.ablation),
        )


def check_choices(cfg: ClosedLoopConfig) -> None:
    """Raise UnknownChoiceError/ConfigError naming a bad task, backend, segmenter or tracker (and its
    options) before anything is created or run."""
    import code_as_monitor.sim.tasks  # noqa: F401  (registers the tasks)
    from code_as_monitor.sim.cameras import check_views_kept
    from code_as_monitor.sim.tasks.base import TaskConfig

    TaskConfig.from_name(cfg.task, **cfg.task_params)
    monitor = cfg.monitor_config()
    monitor.check()
    check_views_kept(cfg.cameras, monitor.cameras, f"ablation {cfg.ablation!r}")


def make_checked_backend(cfg: ClosedLoopConfig) -> Any:
    """Check every choice and build the VLM backend (a missing API key or a bad server URL is found
    here, before a run directory exists). Returns the backend for :func:`run_closed_loop`."""
    from code_as_monitor.vlm import VLMBackendConfig, make_backend

    check_choices(cfg)
    return make_backend(VLMBackendConfig.from_name(cfg.backend, **cfg.backend_options))


def _settle_and_evaluate(env: Any, policy_done_reason: str) -> Any:
    """Let the world run on (the policy halted) until the task's evaluation time, then evaluate."""
    from code_as_monitor.sim.episode import SETTLE_S

    world, limit = env.world, env.task.config.time_limit
    end = min(limit, world.t + SETTLE_S) if env.task.settle_after_plan() else limit
    while world.t < end - 1e-9:
        env.policy.step()
    return env.evaluate()


def early_end(exc: BaseException) -> tuple[str, str]:
    """(outcome, one-line reason) of a run stopped by ``exc``: ``interrupted`` or ``error``."""
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted", "interrupted (Ctrl-C or SIGTERM)"
    return "error", f"{type(exc).__name__}: {exc}"


def run_closed_loop(
    cfg: ClosedLoopConfig, run_dir: Path | None = None, on_event: EventCallback | None = None,
    on_env: Callable[[Any], None] | None = None, backend: Any = None,
    on_observation: Callable[[Any, bool], None] | None = None, frame_hooks: list[Callable[..., None]] | None = None,
) -> dict[str, Any]:
    """Run one Code-as-Monitor episode; returns the summary (also written to ``run_dir/summary.json``).

    ``run_dir`` (created by the caller, fresh) receives ``events.jsonl`` (agent events, flushed as
    written), ``ground_truth.jsonl`` (the simulator's disturbance/consequence log), ``episode.mp4``,
    ``prompts/`` and ``programs/``. ``on_env`` is called with the ``SimEnv`` once it exists (the
    benchmark uses it to run counterfactual rollouts from inside ``on_event``). ``backend``: a VLM
    backend already built by :func:`make_checked_backend`. ``on_observation(obs, policy_done)`` sees
    every frame the monitor takes (a bag recorder); ``frame_hooks`` get every judged frame with its
    elements and verdicts (a live viewer).

    An exception or an interrupt still writes ``summary.json`` (outcome ``error`` / ``interrupted``)
    and is then re-raised.
    """
    from code_as_monitor.agent.drive import drive
    from code_as_monitor.agent.monitor import build_monitor
    from code_as_monitor.sim.camera_file import is_camera_file
    from code_as_monitor.sim.cameras import camera_set
    from code_as_monitor.sim.env import make_env
    from code_as_monitor.sim.world import WorldConfig
    from code_as_monitor.vlm.skills import skill_table

    wall0 = time.perf_counter()
    out = RunArtefacts(run_dir, cfg.camera_hz if cfg.video else None, on_event)
    out.frame_hooks.extend(frame_hooks or [])
    # Views are rendered when read (and before the world moves on): the oracle tracker reads poses, not
    # pixels, so its frames cost no render.
    cameras = camera_set(cfg.cameras, cfg.width, cfg.height)
    world_cfg = WorldConfig(width=cfg.width, height=cfg.height, camera_hz=cfg.camera_hz, defer_render=True,
                            cameras=cameras, robot_visual=cfg.robot_visual)
    monitor = None
    summary: dict[str, Any] = {"method": "cam", "config": asdict(cfg), "task": cfg.task, "seed": cfg.seed}
    if is_camera_file(cfg.cameras):  # the file may change later: the run says which views it had
        summary["camera_specs"] = [asdict(c) for c in cameras or []]
    try:
        with make_env(cfg.task, seed=cfg.seed, world_config=world_cfg, **cfg.task_params) as env:
            if run_dir is not None:
                env.world.events.open(run_dir / "ground_truth.jsonl")
            if on_env is not None:
                on_env(env)
            monitor = build_monitor(cfg.monitor_config(env.task.config.time_limit), on_event=out.emit,
                                    on_frame=out.on_frame, on_prompt=out.on_prompt, backend=backend,
                                    skills=skill_table(env.policy.skills))
            episode = drive(monitor, env.instruction, env.world, env.policy, on_observation=on_observation)
            result = _settle_and_evaluate(env, episode.stop_reason)
            gt_events = list(env.world.events.events)
            env.world.events.close()
            t_end = env.world.t
    except BaseException as exc:
        outcome, reason = early_end(exc)
        summary.update(outcome=outcome, success=False, reason=reason, error=reason,
                       wall_time_s=round(time.perf_counter() - wall0, 2))
        if monitor is not None:
            summary.update(episode=monitor.episode.to_dict(), vlm=monitor.usage.to_dict())
        finish_early(out, monitor, run_dir, summary, outcome, reason)
        raise
    monitor.close()
    usage = monitor.usage
    outcome = "error" if episode.error is not None else ("success" if result.success else "failure")
    summary.update({
        "outcome": outcome,
        "success": bool(result.success),
        "reason": result.reason,
        "error": f"planner failed: {episode.error}" if episode.error is not None else None,
        "sim_time_s": round(float(episode.t_end), 3),
        "sim_time_end_s": round(float(t_end), 3),
        "wall_time_s": round(time.perf_counter() - wall0, 2),
        "episode": episode.to_dict(),
        "vlm": usage.to_dict(),
        "ground_truth_events": gt_events,
        "task_info": result.info,
    })
    out.emit("outcome", outcome=outcome, success=summary["success"], reason=result.reason,
             sim_time_s=summary["sim_time_s"], vlm_calls=usage.calls, vlm=usage.episode())
    out.close()
    if run_dir is not None:
        write_json(run_dir / "summary.json", summary)
    return summary
