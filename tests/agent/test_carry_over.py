"""The checker remembers where its tracker last had each part and hands that to the painter at the next subgoal's
start (the painter decides whether to carry it over: tests/painter/test_robot_occlusion_on_sim.py); the painter's
decisions are events."""

from __future__ import annotations

import numpy as np
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.painter.carry_over import CarryDecision


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
