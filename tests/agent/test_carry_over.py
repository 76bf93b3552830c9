"""The checker remembers where its tracker last had each part and hands that to the painter at the next subgoal's
start (the painter decides whether to carry it over: tests/painter/test_robot_occlusion_on_sim.py); the painter's
decisions are events."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.core.elements import ElementSupport
from code_as_monitor.painter.carry_over import CarryDecision, evidence
from code_as_monitor.perception.trackers.base import TrackResult


class RecordingPainter(Painter):
    """Records the remembered estimates each paint gets; reports one carry-over decision when it gets any."""

    def __init__(self) -> None:
        self.known: list[dict | None] = []

    def paint(self, obs, subgoal, known=None):
        self.known.append(None if known is None else dict(known))
        res = super().paint(obs, subgoal)
        if known:
            res.carried = [CarryDecision(0, "block", True, "test", {"from_t": 0.0})]
        return res


class RecordingTracker(Tracker):
    """Records each step's time and points."""

    def __init__(self, world: World) -> None:
        super().__init__(world)
        self.steps: list = []

    def step(self, obs):
        tr = super().step(obs)
        self.steps.append((obs.t, tr.points))
        return tr


def test_the_next_subgoal_is_painted_with_where_the_tracker_last_had_each_part() -> None:
    w = World()
    painter = RecordingPainter()
    tracker = RecordingTracker(w)
    events: list = []
    checker = CodeChecker(Coder(), painter, tracker, Runtime(RULES), History, AgentConfig())
    monitor = Monitor(Planner([_subgoal("move block", during=False), _subgoal("move it again", during=False)]),
                      checker, on_event=lambda kind, **f: events.append((kind, f)))
    user_loop(monitor, w, MovePolicy(w, stop_at=0.25))
    assert painter.known[0] is None, "nothing is remembered at the first subgoal"
    known = painter.known[1]
    assert list(known) == [("block", "", "point")]
    k = known[("block", "", "point")]
    # where the tracker had the block on the first subgoal's last frame (the last step before the second paint)
    t_last, pts = [s for s in tracker.steps if s[0] <= k.t][-1]
    assert k.t == t_last and np.allclose(k.points, pts[0]) and k.points[0, 0] >= 0.2
    carry = [f for kind, f in events if kind == "element_carry"]
    assert carry and carry[0]["carried"] is True and carry[0]["name"] == "block"


def test_a_new_episode_forgets_what_the_last_one_remembered() -> None:
    w = World()
    painter = RecordingPainter()
    checker = CodeChecker(Coder(), painter, Tracker(w), Runtime(RULES), History, AgentConfig())
    for _ in range(2):
        monitor = Monitor(Planner([_subgoal("move block", during=False)]), checker)
        user_loop(monitor, w, MovePolicy(w, stop_at=0.25))
    assert painter.known == [None, None]


class SurveyingPainter(RecordingPainter):
    """A painter that builds elements by object: the first frame's survey goes through it."""

    connect_points = True

    def __init__(self, visible: set[str]) -> None:
        super().__init__()
        self.visible = visible
        self.surveyed: list[list[str]] = []

    def build_elements(self, obs, specs, texts=None):
        from code_as_monitor.core.elements import Element

        self.surveyed.append([s.obj for s in specs.values()])
        return {i: (Element.point(i, s.name, np.array([0.4, 0.0, 0.02]), (s.obj, s.part)) if s.obj in self.visible
                    else None) for i, s in specs.items()}


def test_the_first_frame_surveys_every_object_so_an_unwatched_one_can_be_carried_over_later() -> None:
    """An object no subgoal has watched yet (the block under the arm at the start of a place) is remembered from
    the episode's first frame; one no view sees then is not remembered, and the robot is never surveyed."""
    w = World()
    painter = SurveyingPainter(visible={"block"})
    checker = CodeChecker(Coder(), painter, Tracker(w), Runtime(RULES), History, AgentConfig())
    monitor = Monitor(Planner([_subgoal("move block", during=False)]), checker)
    user_loop(monitor, w, MovePolicy(w, stop_at=0.25))
    assert painter.surveyed == [["block"]]
    first = painter.known[0]
    assert list(first) == [("block", "", "point")] and first[("block", "", "point")].t == 0.0

    w2 = World()
    hidden = SurveyingPainter(visible=set())
    checker = CodeChecker(Coder(), hidden, Tracker(w2), Runtime(RULES), History, AgentConfig())
    user_loop(Monitor(Planner([_subgoal("move block", during=False)]), checker), w2, MovePolicy(w2, stop_at=0.25))
    assert hidden.surveyed == [["block"]] and hidden.known[0] is None


def test_no_survey_when_the_painter_splits_elements_into_points() -> None:
    w = World()
    painter = SurveyingPainter(visible={"block"})
    painter.connect_points = False
    checker = CodeChecker(Coder(), painter, Tracker(w), Runtime(RULES), History, AgentConfig())
    user_loop(Monitor(Planner([_subgoal("move block", during=False)]), checker), w, MovePolicy(w, stop_at=0.25))
    assert painter.surveyed == [] and painter.known[0] is None


class SupportPainter(Painter):
    """Paints the block as a measurement of 300 points and records the remembered estimates it gets."""

    def __init__(self) -> None:
        self.known: list[dict | None] = []

    def paint(self, obs, subgoal, known=None):
        self.known.append(None if known is None else dict(known))
        res = super().paint(obs, subgoal)
        res.elements = [replace(e, support=ElementSupport(300, 2, 0.001)) for e in res.elements]
        return res


class SupportTracker(Tracker):
    """Reports ``support(frame)`` observations for every element, stale on the frames in ``stale_frames``."""

    def __init__(self, world: World, support, stale_frames=()) -> None:
        super().__init__(world)
        self.support, self.stale_frames = support, set(stale_frames)
        self.steps: list = []

    def step(self, obs):
        n = len(self.steps)
        tr = super().step(obs)
        stale = n in self.stale_frames
        s = self.support(n)
        self.steps.append((obs.t, s, stale))
        return TrackResult(obs.t, tr.points, {i: np.array([stale]) for i in tr.points}, {i: 2 for i in tr.points},
                           {} if s is None else {i: s for i in tr.points})


def _remembered(tracker) -> tuple:
    w = tracker.w
    painter = SupportPainter()
    checker = CodeChecker(Coder(), painter, tracker, Runtime(RULES), History, AgentConfig())
    monitor = Monitor(Planner([_subgoal("move block", during=False), _subgoal("move it again", during=False)]),
                      checker)
    user_loop(monitor, w, MovePolicy(w, stop_at=0.25))
    return painter.known[1][("block", "", "point")]


def test_a_remembered_estimate_keeps_the_weakest_support_its_tracker_reported_since_the_paint() -> None:
    """A tracked estimate is no better than its tracker's weakest frame (issue 12: LK's drifting estimate of a held
    block was carried over as if it were the paint it started from). Stale frames hold a position, not a new
    estimate: they do not count."""
    tracker = SupportTracker(World(), lambda n: 1.0 if n in (1, 2) else (30.0 - n if n < 5 else 30.0),
                             stale_frames={1, 2})
    k = _remembered(tracker)
    frames = [s for t, s, stale in tracker.steps if t <= k.t and not stale]
    assert len(frames) >= 5 and k.support.tracked == min(frames) == 26.0
    assert evidence(k.support) == 26.0  # not the paint's 300 points


def test_an_exact_tracker_leaves_the_paint_s_evidence_and_a_silent_one_leaves_none() -> None:
    assert evidence(_remembered(SupportTracker(World(), lambda n: math.inf)).support) == 300.0
    assert evidence(_remembered(SupportTracker(World(), lambda n: None)).support) == 0.0
