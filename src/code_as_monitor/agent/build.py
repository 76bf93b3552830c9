"""The one place that builds Code-as-Monitor's stages from a :class:`~code_as_monitor.agent.config.MonitorConfig`.

backend -> planner and coder, segmenter -> painter, tracker, a sandboxed runtime and element histories, wired
into a :class:`~code_as_monitor.agent.code_checker.CodeChecker`.
:meth:`Monitor.from_config <code_as_monitor.agent.monitor.Monitor.from_config>` puts them in a monitor; this
module does not import the monitor (no import circle). The stages' implementations are imported when built.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from code_as_monitor.agent.code_checker import CodeChecker, FrameFn, PromptFn
from code_as_monitor.agent.config import MonitorConfig


@dataclass
class MonitorStages:
    """What :func:`build_stages` builds: the planner (``next_subgoal``; its ``usage`` meters both VLM calls),
    the per-subgoal checker, and the sandbox runtime (its worker is the monitor's to close)."""

    planner: Any
    checker: CodeChecker
    runtime: Any


def build_stages(config: MonitorConfig, on_frame: FrameFn | None = None, on_prompt: PromptFn | None = None,
                 backend: Any = None, skills: dict[str, str] | None = None) -> MonitorStages:
    """Build the stages of Code-as-Monitor from ``config``. ``backend``: an already built backend to use
    instead of ``config.backend`` (e.g. one whose configuration was checked before a run directory was made).
    ``skills``: the policy's skills, name -> description, as the planner is told them (None: every simulator
    skill)."""
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
    from code_as_monitor.vlm import VLMBackendConfig, make_backend

    if backend is None:
        backend = make_backend(VLMBackendConfig.from_name(config.backend, **config.backend_options))
    generator = ConstraintGenerator(backend, skills=skills)
    coder = MonitorCoder(backend, usage=generator.usage)
    painter = Painter(make_segmenter(SegmenterConfig.from_name(config.segmenter, **config.segmenter_options)),
                      element_source=config.element_source, connect_points=config.connect_points)
    tracker = make_tracker(TrackerConfig.from_name(config.tracker, **config.tracker_options))
    if hasattr(tracker, "set_segmenter"):  # the depth tracker detects small objects with it every frame
        tracker.set_segmenter(painter.segmenter)
    runtime = MonitorRuntime(deadline_s=config.deadline_s, allow_unconfined=config.allow_unconfined or None)
    checker = CodeChecker(coder, painter, tracker, runtime, ElementHistory, config.agent_config(),
                          on_frame=on_frame, on_prompt=on_prompt)
    return MonitorStages(generator, checker, runtime)


__all__ = ["MonitorStages", "build_stages"]
