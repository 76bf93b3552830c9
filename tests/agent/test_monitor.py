"""The streaming API: ``Monitor.start`` / ``step(observation) -> Decision`` / ``close``, driven frame by
frame from a loop the test owns (no driver), with fakes for every stage (see ``loop_fakes``)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from loop_fakes import (
    RULES,
    Coder,
    History,
    MovePolicy,
    Painter,
    Planner,
    Runtime,
    Tracker,
    World,
    _subgoal,
    user_loop,
)

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig, MonitorConfig
from code_as_monitor.agent.decision import DecisionKind
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.core import Observation, View
from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ConfigError, ObservationError, VLMError


def _monitor(world: World, planner: Planner, events: list | None = None, **cfg) -> Monitor:
    config = AgentConfig(**cfg)
    checker = CodeChecker(Coder(), Painter(), Tracker(world), Runtime(RULES), History, config)
    emit = (lambda kind, **f: events.append((kind, f))) if events is not None else None
    return Monitor(planner, checker, max_replans=config.max_replans, time_limit_s=config.time_limit_s,
                   on_event=emit)


def test_a_user_loop_gets_start_halt_with_the_violation_then_the_replanned_action_then_task_done() -> None:
    w = World(t_drop=0.3)
    planner = Planner([_subgoal("move block"), _subgoal("move block again", during=False)])
    policy = MovePolicy(w)
    decisions = user_loop(_monitor(w, planner), w, policy)
    kinds = [d.kind for d in decisions if d.kind is not DecisionKind.CONTINUE]
    assert kinds[0] is DecisionKind.START and decisions[0].action.skill == "move"
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    assert halt.halt and [a.constraint_id for a in halt.violations] == ["attached"]
    assert "violated" in halt.violations[0].reason and halt.ended.outcome == "violated"
    assert halt.action is not None and halt.subgoal.text == "move block again", "re-planned at the same frame"
    assert halt.t == pytest.approx(0.3, abs=0.11)
    assert decisions[-1].kind is DecisionKind.TASK_DONE and decisions[-1].finished
    assert planner.calls[1][1].startswith("failure: attached")


def test_frames_that_are_not_due_are_skipped() -> None:
    """A 50 Hz camera into a 10 Hz monitor: about one frame in five is looked at."""
    w = World()
    seen: list[float] = []
    tracker = Tracker(w)
    real = tracker.step
    tracker.step = lambda obs: (seen.append(obs.t), real(obs))[1]
    checker = CodeChecker(Coder(), Painter(), tracker, Runtime(RULES), History, AgentConfig(frame_hz=10.0))
    m = Monitor(Planner([_subgoal("move", during=True, upon=False)]), checker)
    decisions = user_loop(m, w, MovePolicy(w, speed=0.05, stop_at=0.2), camera_hz=50.0)
    assert decisions[-1].kind is DecisionKind.TASK_DONE
    gaps = np.diff(seen[: len(seen) - 6])  # the settle frames after the policy finished are one period apart too
    assert len(gaps) > 10 and np.all(gaps > 0.09 - 1e-9), gaps


def test_upon_checks_complete_the_subgoal_and_halt_a_moving_policy() -> None:
    w = World()
    decisions = user_loop(_monitor(w, Planner([_subgoal("move")])), w, MovePolicy(w))
    done = next(d for d in decisions if d.kind is not DecisionKind.START and d.ended is not None)
    assert done.ended.outcome == "success" and done.halt
    assert decisions[-1].kind is DecisionKind.TASK_DONE and done is decisions[-1]


def test_planner_backend_error_stops_with_the_error_recorded() -> None:
    class Broken:
        def next_subgoal(self, *a):
            raise VLMError("server unreachable at http://127.0.0.1:9")

    w = World()
    events: list = []
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History)
    m = Monitor(Broken(), checker, on_event=lambda k, **f: events.append(k))
    m.start("anything")
    d = m.step(w.observe())
    assert d.kind is DecisionKind.STOPPED and d.finished and d.action is None
    assert m.episode.error and "unreachable" in m.episode.error
    assert "planner_error" in events and events[-1] == "episode_end"


def test_misuse_raises_specific_errors() -> None:
    w = World()
    m = _monitor(w, Planner([_subgoal("move")]))
    with pytest.raises(ConfigError, match=r"before Monitor\.start"):
        m.step(w.observe())
    with pytest.raises(ConfigError, match="instruction"):
        m.start("  ")
    m.start("move the block")
    w.t = 1.0
    m.step(w.observe())
    w.t = 0.5
    with pytest.raises(ObservationError, match="backwards"):
        m.step(w.observe())


def test_cameras_select_views_and_a_missing_one_is_named() -> None:
    cam = CameraModel.look_at("front", np.array([1.0, 0, 1]), np.zeros(3), 32, 24, 60.0)
    view = View(np.zeros((24, 32, 3), np.uint8), np.ones((24, 32), np.float32), cam)
    w = World()
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History)
    m = Monitor(Planner([]), checker, cameras=["wrist"])
    m.start("x")
    with pytest.raises(ObservationError, match="'wrist'"):
        m.step(Observation(0.0, {"front": view}))


@pytest.mark.parametrize(("field_", "value"), [("frame_hz", 0.0), ("cameras", []), ("settle_frames", -1),
                                               ("time_limit_s", 0.0)])
def test_monitor_config_names_the_bad_field(field_: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field_):
        MonitorConfig(**{field_: value})


def test_bad_stage_name_is_found_by_check() -> None:
    with pytest.raises(ConfigError, match="nosuch"):
        MonitorConfig(tracker="nosuch").check()


def test_the_public_api_imports_no_simulator() -> None:
    code = ("import sys, code_as_monitor as c; c.Monitor; c.MonitorConfig; c.Decision;"
            "import code_as_monitor.agent.drive, code_as_monitor.agent.loop;"
            "bad = [m for m in sys.modules if m.startswith(('code_as_monitor.sim', 'pybullet'))]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_from_config_builds_the_stages_from_their_names():
    from code_as_monitor.agent.monitor import build_monitor

    skills = {"pick": "pick an object up", "place": "put the held object down"}
    with build_monitor(MonitorConfig(backend="kb", segmenter="sim", tracker="sim", max_replans=3),
                       skills=skills) as m:
        assert m.planner.skills == skills and m.usage is m.planner.usage
        assert type(m.checker).__name__ == "CodeChecker" and m.max_replans == 3
    with Monitor.from_config(MonitorConfig(backend="kb", segmenter="sim", tracker="sim")) as m:
        assert "pick" in m.planner.skills and len(m.planner.skills) > 2  # every simulator skill


class _RejectingCoder(Coder):
    """Never produces a program (as when every candidate fails validation)."""

    def write_program(self, subgoal, elements, images, check, max_retries=2, feedback=None):
        from code_as_monitor.core.errors import ProgramError

        self.checked += 1
        raise ProgramError("check_x returned True on all 12 inputs")


class _SamePlanner:
    """A deterministic planner: the same subgoal whatever the feedback (the kb after a coder failure)."""

    def __init__(self, texts: list[str]) -> None:
        self.texts = texts
        self.calls = 0

    def next_subgoal(self, instruction, images, objects, previous, feedback):
        self.calls += 1
        return _subgoal(self.texts[(self.calls - 1) % len(self.texts)])


@pytest.mark.parametrize("max_same_start", [1, 3])
def test_the_same_subgoal_that_cannot_start_on_one_observation_stops_the_episode_as_stuck(max_same_start: int) -> None:
    """Nothing moves while the planner re-plans on one observation: a subgoal whose program the coder cannot
    write is proposed ``max_same_start`` times, then the episode stops with that reason, long before the
    re-plan bound (30), and without starting the policy."""
    w = World()
    events: list = []
    coder = _RejectingCoder()
    checker = CodeChecker(coder, Painter(), Tracker(w), Runtime(RULES), History, AgentConfig())
    planner = _SamePlanner(["grasp the pen"])
    m = Monitor(planner, checker, max_replans=30, max_same_start=max_same_start,
                on_event=lambda k, **f: events.append((k, f)))
    m.start("put the pen in the holder")
    d = m.step(w.observe())
    assert d.finished and d.kind is DecisionKind.STOPPED and d.action is None
    assert planner.calls == coder.checked == max_same_start
    assert m.episode.replans == max_same_start
    assert m.episode.stop_reason.startswith("stuck: the planner proposed 'grasp the pen'")
    assert "check_x returned True on all 12 inputs" in m.episode.stop_reason
    assert [f["times"] for k, f in events if k == "stuck"] == [max_same_start]


def test_different_subgoals_that_cannot_start_run_to_the_replan_bound() -> None:
    """Only an identical proposal counts: a planner that changes its subgoal after each failure is given the
    whole re-plan bound (the guard is not a second, smaller bound)."""
    w = World()
    coder = _RejectingCoder()
    checker = CodeChecker(coder, Painter(), Tracker(w), Runtime(RULES), History, AgentConfig())
    planner = _SamePlanner([f"grasp the pen, try {i}" for i in range(40)])
    m = Monitor(planner, checker, max_replans=5, max_same_start=2)
    m.start("put the pen in the holder")
    d = m.step(w.observe())
    assert d.finished and m.episode.replans == 6 and planner.calls == 6
    assert m.episode.stop_reason == "too many re-plans (6)"


def test_a_subgoal_that_failed_while_running_is_not_counted_as_stuck() -> None:
    """The guard is per observation: the same subgoal re-proposed after it ran (the world moved) starts."""
    w = World(t_drop=0.1)
    planner = Planner([_subgoal("move block") for _ in range(4)])
    m = _monitor(w, planner, max_replans=10)
    m.max_same_start = 1
    decisions = user_loop(m, w, MovePolicy(w))
    starts = [d for d in decisions if d.action is not None]
    assert len(starts) == 4 and "stuck" not in (m.episode.stop_reason or "")
