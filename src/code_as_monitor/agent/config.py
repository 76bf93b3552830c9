"""Settings of the closed loop and of a Code-as-Monitor :class:`~code_as_monitor.agent.monitor.Monitor`.

:class:`AgentConfig` holds the loop's own settings (rate, bounds, dwell, settle); :class:`MonitorConfig`
adds the swappable stages, chosen by their registered names: the VLM backend (planner and coder), the
segmenter, the tracker, and which cameras to use. :mod:`code_as_monitor.agent.build` builds the stages from them.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from code_as_monitor.agent.check_modes import check_mode
from code_as_monitor.agent.records import DEFAULT_MAX_REPLANS, DEFAULT_MAX_SAME_START, DEFAULT_MAX_SUBGOALS
from code_as_monitor.agent.rest import RestWait
from code_as_monitor.core.checks import DEADLINE_S_RANGE, RATE_HZ_RANGE, check_count, check_fields, check_range
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.painter.sources import check_element_source
from code_as_monitor.vlm.skills import RUN_TO_END


@dataclass
class AgentConfig:
    """Closed-loop settings.

    Attributes:
        frame_hz: monitoring rate (frames per second of observation time).
        max_replans: failed subgoals allowed before giving up.
        max_subgoals: hard bound on subgoals per episode.
        max_same_start: proposals of one identical subgoal that could not start, on one observation, before
            the episode stops as stuck (the world has not moved in between; see ``DEFAULT_MAX_SAME_START``).
        time_limit_s: no subgoal is planned at or after this time (observation seconds); None for none.
        history_len: frames of element history fed to the program as H.
        code_retries: regenerations allowed when validation or path coverage fails.
        halt_on_upon: halt a still-moving policy as soon as every upon check holds, unless its skill is one of
            ``run_to_end`` (then its upon checks are judged when it finishes).
        run_to_end: skills whose motion is their goal, never halted early on their upon checks (default: the
            pour, :data:`code_as_monitor.vlm.skills.RUN_TO_END`); a robot names its own.
        upon_dwell_frames: consecutive frames the upon checks must hold before completing.
        refresh_on_done: when the policy finishes, re-measure the elements before judging the upon
            checks, so tracker drift accumulated during the motion does not decide the outcome: an element
            the tracker saw move more than ``refresh_motion`` during the subgoal (the carried object) is
            re-painted from the current, static frame; one it saw at rest keeps its measurement from the
            subgoal start (re-painting it now would measure whatever is left visible, e.g. the sides of a
            block another block now covers), unless that measurement was weak (its ``ElementSupport``, e.g.
            painted mostly through the robot's arm) and one from the static frame is not. Robot elements
            follow forward kinematics either way.
        refresh_motion: metres of tracked centroid motion over the subgoal above which an element counts
            as moved.
        rest_motion: metres an element the last subgoal's checks read must have moved since the completion was
            judged for the done check at rest (``check_done_at_rest``) to judge them again; 0 (default): whenever
            any such element moved at all (a bound of centimetres keeps completions a rope sliding open after the
            halt has undone).
        settle_frames: when the policy has finished but an upon check has no verdict (a program fault,
            or a stale element), wait up to this many frames for one before calling it a failure.
        rest_max_s: after a halt or a failed subgoal, re-plan once the scene has come to rest (the depth images
            stop changing; :class:`~code_as_monitor.agent.rest.RestWait`), but after at most this many seconds;
            0: re-plan on the failing frame.
        rest_still_frames: consecutive monitored frames without motion that count as at rest.
        rest_depth_tol: metres of depth change above which a pixel counts as moved.
        rest_noise_k: that tolerance rises to this many times the depth noise estimated from the compared frames
            (a noisy depth camera); 0 keeps ``rest_depth_tol``.
        checks: which of each subgoal's checks run (an ablation switch, :mod:`~code_as_monitor.agent.check_modes`):
            ``all`` (default), ``reactive`` (only constraints with ``proactive`` False) or ``proactive`` (only
            those with it True). The planner and the feedback are unchanged; the dropped constraints are neither
            painted nor coded nor checked.
    """

    frame_hz: float = 10.0
    max_replans: int = DEFAULT_MAX_REPLANS
    max_subgoals: int = DEFAULT_MAX_SUBGOALS
    max_same_start: int = DEFAULT_MAX_SAME_START
    time_limit_s: float | None = None
    history_len: int = 64
    code_retries: int = 2
    halt_on_upon: bool = True
    run_to_end: tuple[str, ...] = RUN_TO_END
    upon_dwell_frames: int = 2
    refresh_on_done: bool = True
    refresh_motion: float = 0.03
    rest_motion: float = 0.0
    settle_frames: int = 5
    rest_max_s: float = 1.5
    rest_still_frames: int = 2
    rest_depth_tol: float = 0.005
    rest_noise_k: float = 5.0
    check_done_at_rest: bool = True
    checks: str = "all"

    def __post_init__(self) -> None:
        name = type(self).__name__
        # types first (a string, a bool or None where a number goes), then ranges; each error names the value
        check_fields(name, type(self), {f.name: getattr(self, f.name) for f in dataclasses.fields(self)})
        check_range(name, "frame_hz", self.frame_hz, *RATE_HZ_RANGE)
        check_count(name, "max_replans", self.max_replans, 0)
        check_count(name, "max_subgoals", self.max_subgoals, 1)
        check_count(name, "max_same_start", self.max_same_start, 1)
        check_count(name, "history_len", self.history_len, 2)
        if self.time_limit_s is not None:
            check_range(name, "time_limit_s", self.time_limit_s, 0.0, None, lo_open=True)
        for f in ("code_retries", "upon_dwell_frames", "settle_frames"):
            check_count(name, f, getattr(self, f), 0)
        check_range(name, "refresh_motion", self.refresh_motion, 0.0, None)
        check_range(name, "rest_motion", self.rest_motion, 0.0, None)
        check_range(name, "rest_max_s", self.rest_max_s, 0.0, None)
        check_count(name, "rest_still_frames", self.rest_still_frames, 1)
        check_range(name, "rest_depth_tol", self.rest_depth_tol, 0.0, None, lo_open=True)
        check_range(name, "rest_noise_k", self.rest_noise_k, 0.0, None)
        check_mode(self.checks, f"{name}.checks")
        if isinstance(self.run_to_end, str) or not isinstance(self.run_to_end, (tuple, list)) or not all(
                isinstance(x, str) and x for x in self.run_to_end):
            raise ConfigError(f"{name}.run_to_end must be a list of skill names, got {self.run_to_end!r}")
        self.run_to_end = tuple(self.run_to_end)


    def rest_wait(self) -> RestWait:
        """The re-plan wait these settings describe (compared frames one monitoring period apart)."""
        return RestWait(max_s=self.rest_max_s, period_s=1.0 / self.frame_hz, still_frames=self.rest_still_frames,
                        depth_tol=self.rest_depth_tol, noise_k=self.rest_noise_k)


@dataclass
class MonitorConfig(AgentConfig):
    """A Code-as-Monitor monitor: the loop settings plus the stages, chosen by registered name.

    Attributes:
        backend, backend_options: the VLM backend for the planner and the coder (``kb``: a rule-based
            stand-in for a VLM, not a VLM; ``openai``: any OpenAI-compatible server; ``replay``).
        segmenter, segmenter_options: ``sim`` (ground-truth masks in ``View.seg``), ``color``, ``http``.
        tracker, tracker_options: ``depth`` (the default: each element's object cloud registered to the depth
            images, no simulator pose; what RESULTS.md measures), ``lk`` (OpenCV Lucas-Kanade on the images, lifted
            with depth), ``sim`` (oracle poses), ...
        cameras: view names the monitor uses; None: every view of each observation.
        deadline_s: the sandbox's per-frame deadline for running every check (seconds); a frame past
            it is a program fault for every check (no verdict). 20 ms suits 10 Hz on an idle machine.
        element_source: how the painter forms elements (an ablation switch, ``painter.ELEMENT_SOURCES``):
            ``part-masks`` (default: the segmenter's constraint-aware instance and part masks) or
            ``orb-keypoints`` (classical OpenCV ORB keypoints on the object's image region, lifted with depth and
            clustered with scikit-learn k-means: our offline analogue of the paper's "CS off" row, which used
            DINOv2 points; it is not DINOv2, and it knows no parts).
        connect_points: form line and surface elements (default). False (the paper's "CP off"): every element
            is handed over as unconnected 3-D points (a line as its two ends, a surface as its corners, each a
            point element of its own); the coder must recombine them in code.
        allow_unconfined: run generated monitor code even where the worker's kernel confinement (seccomp,
            no_new_privs, namespaces) cannot be installed: an explicit opt-out, off by default (then such a
            machine refuses to run generated code and says why). ``CAM_ALLOW_UNCONFINED=1`` does the same.
    """

    backend: str = "kb"
    backend_options: dict[str, Any] = field(default_factory=dict)
    segmenter: str = "sim"
    segmenter_options: dict[str, Any] = field(default_factory=dict)
    tracker: str = "depth"
    tracker_options: dict[str, Any] = field(default_factory=dict)
    cameras: list[str] | None = None
    deadline_s: float = 0.020
    allow_unconfined: bool = False
    element_source: str = "part-masks"
    connect_points: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        check_element_source(self.element_source, "MonitorConfig.element_source")
        if not isinstance(self.connect_points, bool):
            raise ConfigError(f"MonitorConfig.connect_points must be true or false, got {self.connect_points!r}")
        check_range("MonitorConfig", "deadline_s", self.deadline_s, *DEADLINE_S_RANGE)
        if not isinstance(self.allow_unconfined, bool):
            raise ConfigError(f"MonitorConfig.allow_unconfined must be true or false, got {self.allow_unconfined!r}")
        for f in ("backend_options", "segmenter_options", "tracker_options"):
            if not isinstance(getattr(self, f), dict):
                raise ConfigError(f"MonitorConfig.{f} must be a dict of options, got {getattr(self, f)!r}")
        if self.cameras is not None and not isinstance(self.cameras, list | tuple):
            raise ConfigError(f"MonitorConfig.cameras must be a non-empty list of view names or None, "
                              f"got {self.cameras!r}")
        if self.cameras is not None and (not self.cameras or not all(isinstance(c, str) and c for c in self.cameras)):
            raise ConfigError(f"MonitorConfig.cameras must be a non-empty list of view names or None, "
                              f"got {self.cameras!r}")

    def check(self) -> None:
        """Raise UnknownChoiceError / ConfigError naming a bad backend, segmenter or tracker (or one of
        their options), without building anything."""
        from code_as_monitor.perception import SegmenterConfig, TrackerConfig
        from code_as_monitor.vlm import VLMBackendConfig

        VLMBackendConfig.from_name(self.backend, **self.backend_options)
        SegmenterConfig.from_name(self.segmenter, **self.segmenter_options)
        TrackerConfig.from_name(self.tracker, **self.tracker_options)

    def agent_config(self) -> AgentConfig:
        return AgentConfig(**{k: getattr(self, k) for k in AgentConfig.__dataclass_fields__})


__all__ = ["AgentConfig", "MonitorConfig"]
