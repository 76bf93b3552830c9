"""One benchmark episode of any method -> one compact, JSON-serialisable result record.

``cam`` runs through :func:`code_as_monitor.bench.closed_loop.run_closed_loop`; the baselines run
here over the same simulator, planner and VLM backend. Proactive alarms of every method get a
counterfactual rollout (:mod:`code_as_monitor.bench.counterfactual`) from inside the agent's
``on_event("alarm")`` callback, and so do reactive alarms that no logged failure explains when they fire
(:func:`unexplained`). An exception inside an episode is recorded (``error``), not raised,
so one broken cell never stops a sweep.
"""

from __future__ import annotations

import logging
import os
import time
import traceback
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from code_as_monitor.bench.counterfactual import DEFAULT_HORIZON_S, rollout
from code_as_monitor.bench.metrics import FAILURE_KINDS, about
from code_as_monitor.bench.protocol import Job, ablation_of, condition, episode_seed, is_cam
from code_as_monitor.core.checks import check_fields, check_positive
from code_as_monitor.core.errors import ConfigError

log = logging.getLogger(__name__)

RECORD_VERSION = 1
BENCH_DEADLINE_S = 0.5
"""CaM's per-frame sandbox deadline in benchmark episodes, seconds (see ``EpisodeOptions.deadline_s``)."""
OPEN_LOOP_VIDEO_HZ = 2.0
GT_KINDS = ("drop", "regrasped", "block_fell", "tower_collapsed", "placement_noise", "zone_count", "over_swept",
            "opening_enclosed", "opening_open", "object_moved", "grasp_perturbed", "object_knocked", "grasp_slipped",
            "pour_undone", "policy_failure", "placed", "misplaced")
"""Ground-truth kinds kept in a record (robot bookkeeping events are left out to keep it compact)."""
GT_KEYS = ("count", "target", "on", "on_target", "target_offset", "what", "objects", "band", "after", "reason",
           "judged_at")
"""Kind-specific keys kept with them: what the detection metrics read (a drop's target, where it landed)."""


@dataclass
class EpisodeOptions:
    """Method settings shared by every episode of a sweep (stored in the results file's header).

    Attributes:
        backend, backend_options: the VLM backend (``kb`` offline: the baselines then use the
            ``vqa-standin`` single-image stand-in; ``openai``: a real VLM answers their questions).
        doremi_k_s: seconds between DoReMi's VQA checks.
        segmenter, tracker: CaM's perception choices.
        camera_hz: CaM's monitoring rate (frames per second of sim time).
        counterfactual: run counterfactual rollouts at proactive alarms; ``horizon_s`` their length.
        deadline_s: CaM's per-frame sandbox deadline, seconds. Larger than a robot's real-time budget (20 ms,
            ``MonitorConfig``'s default): simulated time waits for the monitor, and a wall-clock budget that
            frames overrun only when the machine is busy would make results depend on its load. A frame that
            still overruns is a fault, as on a robot.
        max_replans: failed subgoals a closed-loop method may re-plan after (None: the agents' default); 0 is
            the RLBench protocol's "a flagged episode is abandoned" (``bench.restarts``).
        cameras: the camera set every method sees (:data:`code_as_monitor.sim.cameras.CAMERA_SETS`; ``task``: each
            task's own views). The baselines' single-image questions then go to the set's view most like the one
            they want (:func:`code_as_monitor.baselines.vqa_views.question_view`).
        robot_visual: how the cameras draw the arm (:data:`code_as_monitor.sim.robot.ROBOT_VISUALS`):
            ``decimated`` (default), its detailed meshes with a fifth of their triangles (under 1 % of the arm's
            pixels change label, about 40 % less render time); ``mesh``, the detailed meshes; or ``hull``, its
            collision meshes (less than half the render time, a plainer, slightly larger arm in every image).
    """

    backend: str = "kb"
    backend_options: dict[str, Any] = field(default_factory=dict)
    doremi_k_s: float = 1.0
    segmenter: str = "sim"
    tracker: str = "sim"
    camera_hz: float = 10.0
    counterfactual: bool = True
    horizon_s: float = DEFAULT_HORIZON_S
    deadline_s: float = BENCH_DEADLINE_S
    max_replans: int | None = None
    cameras: str = "task"
    robot_visual: str = "decimated"  # sim.robot.DEFAULT_ROBOT_VISUAL

    def __post_init__(self) -> None:
        from code_as_monitor.sim.robot import check_robot_visual

        check_fields("EpisodeOptions", EpisodeOptions, asdict(self))
        check_robot_visual("EpisodeOptions", self.robot_visual)
        for name in ("doremi_k_s", "camera_hz", "horizon_s", "deadline_s"):
            check_positive("EpisodeOptions", name, getattr(self, name))
        if self.max_replans is not None and (isinstance(self.max_replans, bool) or not isinstance(self.max_replans, int)
                                             or self.max_replans < 0):
            raise ConfigError(f"EpisodeOptions.max_replans must be None or an integer >= 0, got {self.max_replans!r}")
        if not isinstance(self.cameras, str) or not self.cameras:
            raise ConfigError("EpisodeOptions.cameras must be the name of a camera set or a camera file (.json), "
                              f"got {self.cameras!r}")
        if not isinstance(self.backend_options, dict):
            raise ConfigError(f"EpisodeOptions.backend_options must be a dict, got {self.backend_options!r}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def of_file(cls, options: dict[str, Any]) -> EpisodeOptions:
        """The options a results file's ``bench_start`` line names, a field missing there taking the value it
        had before it existed (:data:`BEFORE_THE_FIELD`), else today's default."""
        return cls(**{**BEFORE_THE_FIELD, **options})


BEFORE_THE_FIELD: dict[str, Any] = {"robot_visual": "mesh"}
"""Options whose default changed after they were recorded: what a file or record without the field ran with
(the arm was drawn with its full meshes until the decimated arm became the default, 2026-12-02)."""


def _compact_gt(events: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for e in events:
        if e["kind"] in GT_KINDS:
            c = {"t": e["t"], "kind": e["kind"], "obj": e.get("obj", "")}
            for k in GT_KEYS:
                if k in e:
                    c[k] = e[k]
            out.append(c)
    return out


def unexplained(alarm: dict[str, Any], events: list[dict[str, Any]]) -> bool:
    """Whether a reactive ``alarm`` (an agent event with ``t`` and ``objects``) has no failure to detect in the
    ground-truth ``events`` logged so far: none of :data:`~code_as_monitor.bench.metrics.FAILURE_KINDS` concerning
    one of its objects within the matching window before it.

    Such an alarm gets a counterfactual rollout too. The alarm halts the policy, and the RLBench-style tasks judge a
    skill when it ends (``policy_failure``), so the halt can come before a failure it saw is ever logged: a block
    caught on the drawer's front and pulled 5 cm out of the grip while it was lowered (put-in-drawer 1789404694,
    the oracle tracker too) raised "block dropped", the halt came before the put-in skill's end, and nothing was
    logged. Whether such an alarm was right is then what the proactive alarms' rule says, the same for every
    method: the open-loop continuation ends with the task failed (that one's did not: the block went into the
    drawer, so the alarm stays a false one)."""
    return not alarm.get("proactive") and not any(e["kind"] in FAILURE_KINDS and about(alarm, e) for e in events)


class _Counterfactuals:
    """``on_event`` hook: a rollout at every proactive alarm and every :func:`unexplained` reactive one, attached
    to the alarm by index."""

    def __init__(self, opts: EpisodeOptions) -> None:
        self.opts = opts
        self.env: Any = None
        self.results: list[dict[str, Any] | None] = []

    def set_env(self, env: Any) -> None:
        self.env = env

    def __call__(self, ev: dict[str, Any]) -> None:
        if ev.get("kind") != "alarm":
            return
        cf = None
        if self.opts.counterfactual and self.env is not None and (
                ev.get("proactive") or unexplained(ev, self.env.world.events.events)):
            cf = rollout(self.env, self.opts.horizon_s)
        self.results.append(cf)


def _alarms(alarms: list[dict[str, Any]], cfs: list[dict[str, Any] | None]) -> list[dict[str, Any]]:
    out = []
    for i, a in enumerate(alarms):
        d = {"t": round(float(a["t"]), 3), "constraint_id": a["constraint_id"], "phase": a["phase"],
             "proactive": bool(a["proactive"]), "reason": str(a["reason"])[:160],
             "objects": list(a.get("objects", []))}
        if i < len(cfs) and cfs[i] is not None:
            d["cf"] = cfs[i]
        out.append(d)
    return out


def _run_cam(task: str, seed: int, params: dict[str, Any], opts: EpisodeOptions, run_dir: Path | None,
             cfs: _Counterfactuals, ablation: str = "full") -> dict[str, Any]:
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop

    cfg = ClosedLoopConfig(task=task, seed=seed, task_params=params, backend=opts.backend, ablation=ablation,
                           backend_options=opts.backend_options, segmenter=opts.segmenter, tracker=opts.tracker,
                           camera_hz=opts.camera_hz, video=run_dir is not None, deadline_s=opts.deadline_s,
                           cameras=opts.cameras, robot_visual=opts.robot_visual,
                           **({} if opts.max_replans is None else {"max_replans": opts.max_replans}))
    s = run_closed_loop(cfg, run_dir, on_event=cfs, on_env=cfs.set_env)
    ep = s["episode"]
    return {"success": s["success"], "reason": s["reason"], "sim_time_s": s["sim_time_s"],
            "alarms": ep["alarms"], "gt": s["ground_truth_events"], "vlm": s["vlm"]["episode"],
            "stop_reason": ep["stop_reason"], "replans": ep["replans"], "frames": None,
            "images": cfs.env.world.frames_rendered if cfs.env is not None else None}


def _run_baseline(method: str, task: str, seed: int, params: dict[str, Any], opts: EpisodeOptions,
                  run_dir: Path | None, cfs: _Counterfactuals) -> dict[str, Any]:
    from code_as_monitor.baselines.agents import CheckingAgent, DoReMiConfig, InnerMonologueConfig, OpenLoopAgent
    from code_as_monitor.baselines.vqa import make_vqa
    from code_as_monitor.bench.closed_loop import _settle_and_evaluate
    from code_as_monitor.planning.generator import ConstraintGenerator
    from code_as_monitor.sim.cameras import camera_set
    from code_as_monitor.sim.env import make_env
    from code_as_monitor.sim.world import WorldConfig
    from code_as_monitor.viz.video import FrameComposer, VideoWriter
    from code_as_monitor.vlm import VLMBackendConfig, make_backend
    from code_as_monitor.vlm.skills import skill_table

    # Open-loop renders nothing of its own; its sample video is rendered at OPEN_LOOP_VIDEO_HZ only.
    fps = OPEN_LOOP_VIDEO_HZ if method == "open-loop" else opts.camera_hz
    video = VideoWriter(run_dir / "episode.mp4", fps=fps) if run_dir is not None else None
    compose = FrameComposer(fps=fps)  # keeps verdict banners up for 1.5 s of video

    def emit(kind: str, **fields: Any) -> None:
        cfs({"kind": kind, **fields})

    try:
        # Views are rendered when read: DoReMi's and Inner Monologue's stand-in reads one view per question.
        wc = WorldConfig(camera_hz=opts.camera_hz, defer_render=True, robot_visual=opts.robot_visual)
        wc = replace(wc, cameras=camera_set(opts.cameras, wc.width, wc.height))
        with make_env(task, seed=seed, world_config=wc, **params) as env:
            cfs.set_env(env)
            limit = env.task.config.time_limit
            frames = 0
            if method == "open-loop":
                usage_ep: dict[str, Any] = {"calls": 0, "prompt_tokens": 0, "completion_tokens": 0,
                                            "total_tokens": 0, "calls_by_purpose": {}, "tokens_by_purpose": {}}

                next_frame = [0.0]

                def tick() -> None:  # only the sample episode renders (for its video)
                    if video is not None and env.world.t >= next_frame[0] - 1e-9:
                        next_frame[0] += 1.0 / OPEN_LOOP_VIDEO_HZ
                        video.write(compose(env.world.observe(), [], None, [], ""))

                agent: Any = OpenLoopAgent(env.plan, limit, on_event=emit, on_tick=tick)
                episode = agent.run(env.instruction, env.world, env.policy)
            else:
                backend = make_backend(VLMBackendConfig.from_name(opts.backend, **opts.backend_options))
                planner = ConstraintGenerator(backend, skills=skill_table(env.policy.skills))
                vqa = make_vqa(opts.backend, backend, planner.usage)
                doremi = method == "doremi"
                bound = {} if opts.max_replans is None else {"max_replans": opts.max_replans}
                cfg = DoReMiConfig(k_s=opts.doremi_k_s, **bound) if doremi else InnerMonologueConfig(**bound)

                def on_frame(obs: Any, banner: str) -> None:
                    if video is not None:
                        video.write(compose(obs, [], None, [], banner))

                agent = CheckingAgent(planner, vqa, cfg, opts.doremi_k_s if doremi else None,
                                      ask_all_at_end=not doremi, time_limit_s=limit, on_event=emit,
                                      on_frame=on_frame)
                episode = agent.run(env.instruction, env.world, env.policy)
                frames = agent.frames
                usage_ep = planner.usage.episode()
            result = _settle_and_evaluate(env, episode.stop_reason)
            gt = list(env.world.events.events)
            images = env.world.frames_rendered
    finally:
        if video is not None:
            for frame in compose.tail():
                video.write(frame)
            video.close()
    return {"success": bool(result.success), "reason": result.reason, "sim_time_s": round(float(episode.t_end), 3),
            "alarms": [a.to_dict() for a in episode.alarms], "gt": gt, "vlm": usage_ep,
            "stop_reason": episode.stop_reason, "replans": episode.replans, "frames": frames, "images": images}


def _cpu_seconds() -> float:
    """CPU seconds of this process, its finished children and the sandbox's fork server with the workers it
    has collected (the monitor's programs): a cost that other load on the machine does not inflate as it
    does wall time."""
    from code_as_monitor.monitor.forkserver import server_cpu_seconds

    t = os.times()
    return t.user + t.system + t.children_user + t.children_system + server_cpu_seconds()


def run_episode(job: Job, opts: EpisodeOptions, video_dir: Path | None = None) -> dict[str, Any]:
    """Run ``job`` and return its result record (see ``RESULTS.md`` for the fields).

    ``video_dir``: a fresh directory for this episode's sample video and artefacts (None: no video).
    """
    cond = condition(job.condition)
    seed = episode_seed(job.condition, job.seed, job.episode)
    wall0, cpu0 = time.perf_counter(), _cpu_seconds()
    cfs = _Counterfactuals(opts)
    rec: dict[str, Any] = {"v": RECORD_VERSION, "condition": job.condition, "method": job.method, "seed": job.seed,
                           "episode": job.episode, "episode_seed": seed, "task": cond.task,
                           "undisturbed": cond.undisturbed,
                           "tracker": opts.tracker if is_cam(job.method) else None}
    if is_cam(job.method):
        from code_as_monitor.bench.commands import run_command

        rec["ablation"] = ablation_of(job.method)
        rec["run"] = run_command(cond.task, seed, dict(cond.params), opts.to_dict(), rec["ablation"])
    if video_dir is not None:
        video_dir.mkdir(parents=True, exist_ok=True)
    try:
        if is_cam(job.method):
            out = _run_cam(cond.task, seed, dict(cond.params), opts, video_dir, cfs, ablation_of(job.method))
        else:
            out = _run_baseline(job.method, cond.task, seed, dict(cond.params), opts, video_dir, cfs)
        vlm = out["vlm"]
        rec.update(
            success=bool(out["success"]), reason=str(out["reason"])[:200], sim_time_s=out["sim_time_s"],
            stop_reason=out["stop_reason"], replans=out["replans"], frames=out["frames"], images=out["images"],
            vlm={k: vlm.get(k, 0) for k in ("calls", "prompt_tokens", "completion_tokens", "total_tokens",
                                             "calls_by_purpose", "tokens_by_purpose")},
            alarms=_alarms(out["alarms"], cfs.results), gt=_compact_gt(out["gt"]), error=None,
        )
    except Exception as exc:  # recorded, not raised: one broken cell must not stop a sweep
        log.warning("episode %s failed: %s", job.key, exc)
        rec.update(success=False, reason="error", sim_time_s=None, stop_reason="error", replans=0, frames=None,
                   images=None,
                   vlm={"calls": 0, "prompt_tokens": 0, "completion_tokens": 0, "total_tokens": 0,
                        "calls_by_purpose": {}, "tokens_by_purpose": {}}, alarms=[], gt=[],
                   error=f"{type(exc).__name__}: {exc}"[:300], traceback=traceback.format_exc()[-1500:])
    rec["wall_time_s"] = round(time.perf_counter() - wall0, 3)
    rec["cpu_time_s"] = round(_cpu_seconds() - cpu0, 3)
    rec["video"] = str(video_dir / "episode.mp4") if video_dir is not None and (video_dir / "episode.mp4").exists() \
        else None
    return rec


__all__ = ["GT_KINDS", "RECORD_VERSION", "EpisodeOptions", "run_episode"]
