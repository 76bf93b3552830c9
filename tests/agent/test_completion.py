"""A subgoal completes on its upon checks only if they hold on re-measured elements too (``agent.completion``).

Fakes from ``loop_fakes``: one block moved along x towards a goal at x >= 0.2 m. The tracker here drifts 3 cm ahead of
the block, so on tracked positions the upon check "arrived" holds before the block gets there; the painter measures
the block where it is.
"""

from __future__ import annotations

import numpy as np
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.decision import DecisionKind
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.agent.rest import RestWait
from code_as_monitor.core import Element, Observation, View
from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import ElementSupport

DRIFT = 0.03
CAM = CameraModel.look_at("front", np.array([1.0, 0, 1]), np.zeros(3), 64, 48, 60.0)


class DriftingTracker(Tracker):
    def step(self, obs):
        tr = super().step(obs)
        return type(tr)({i: p + np.array([[DRIFT, 0.0, 0.0]]) for i, p in tr.points.items()}, tr.stale)


class MeasuringPainter(Painter):
    """Paints the block where it is (a strong measurement: many points, two views, nothing hidden)."""

    def __init__(self, world: World) -> None:
        self.w = world
        self.built = 0

    def build_element(self, obs, i, spec):
        self.built += 1
        sup = ElementSupport(points=200, views=2, residual=0.001, spread=0.02, extent=(0.04, 0.04, 0.04))
        return Element.point(i, spec.name, np.array([self.w.x, 0.0, 0.1]), (spec.obj, spec.part), support=sup)


def _run(stop_at: float, refresh: bool = True) -> tuple[Monitor, list, list, MeasuringPainter]:
    w = World()
    painter = MeasuringPainter(w)
    checker = CodeChecker(Coder(), painter, DriftingTracker(w), Runtime(RULES), History,
                          AgentConfig(refresh_on_done=refresh))
    events: list = []
    m = Monitor(Planner([_subgoal("move block", during=False)]), checker, max_replans=0,
                on_event=lambda k, **f: events.append((k, f)))
    decisions = user_loop(m, w, MovePolicy(w, stop_at=stop_at))
    return m, decisions, events, painter


def test_a_drifting_tracker_does_not_complete_a_subgoal_the_block_has_not_done() -> None:
    """The block stops at 0.18 m (the goal needs 0.2): the tracker reads 0.21 and the upon check holds on it, but not
    on the block painted again; the subgoal ends in a reactive failure at the policy's end, not in success."""
    m, _, events, painter = _run(stop_at=0.18)
    assert m.episode.subgoals[0].outcome == "reactive_failure", m.episode.subgoals[0]
    unconfirmed = [f for k, f in events if k == "completion_check" and not f["confirmed"]]
    assert unconfirmed and painter.built > 0
    assert not [k for k, _ in events if k == "early_halt"]


def test_without_refresh_the_tracked_positions_decide_as_before() -> None:
    m, _, events, _ = _run(stop_at=0.18, refresh=False)
    assert m.episode.subgoals[0].outcome == "success"
    assert not [k for k, _ in events if k == "completion_check"]


def test_a_block_that_did_arrive_completes_and_halts_the_policy_early() -> None:
    """Confirmed on the re-measured block (0.25 m of a 0.3 m move when the check first holds), the subgoal ends in
    success while the policy still moves (an early halt), and the next subgoal starts from the measurement."""
    m, decisions, events, _ = _run(stop_at=0.3)
    assert m.episode.subgoals[0].outcome == "success"
    confirmed = [f for k, f in events if k == "completion_check" and f["confirmed"]]
    assert confirmed and [k for k, _ in events if k == "early_halt"]
    assert any(d.halt for d in decisions)


class LingeringPolicy(MovePolicy):
    """Moves the block to ``stop_at``, then holds still for ``linger_s`` before it reports done."""

    def __init__(self, world: World, stop_at: float, linger_s: float) -> None:
        super().__init__(world, stop_at=stop_at)
        self.linger_s, self._still_since = linger_s, None

    def step(self) -> None:
        was_done = self._done
        super().step()
        if was_done or not self._done:
            return
        if self._still_since is None:
            self._still_since = self.w.t
        if self.w.t - self._still_since < self.linger_s:
            self._done = False  # still "running": the block stays where it is


class ShortHistory(History):
    """The fakes' history, keeping only the last ``n`` frames (as the real one, ``history_len``)."""

    def __init__(self, n: int) -> None:
        super().__init__(n)
        self.n = n

    def push(self, t, pts) -> None:
        super().push(t, pts)
        del self.items[:-self.n]


class StirredWorld(World):
    """The fake world with one depth view in which something that is not an element (a cable, a hand) moves at
    2.2-2.6 s, so the wait for rest before the task is called complete sees motion and judges again."""

    def observe(self) -> Observation:
        d = np.full((48, 64), 1.0, np.float32)
        col = 5 + int(20 * min(max(self.t - 2.2, 0.0), 0.4))
        d[30:36, col:col + 6] = 0.9
        return Observation(t=self.t, views={"front": View(np.zeros((48, 64, 3), np.uint8), d, CAM)}, objects=["block"])


def test_an_element_moved_early_in_a_subgoal_longer_than_the_history_is_not_taken_for_one_at_rest() -> None:
    """A history of 3 frames (0.3 s) on a subgoal that moved the block 25 cm and then held it still for 1 s: over the
    history the block did not move, but it is 25 cm from where it was painted at the subgoal's start, so it is not
    "at rest all along" and its start measurement does not stand in for it (that measurement failed the check)."""
    w = StirredWorld()
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), ShortHistory,
                          AgentConfig(halt_on_upon=False, history_len=3))
    events: list = []
    m = Monitor(Planner([_subgoal("move block", during=False)]), checker, max_replans=0, rest=RestWait(max_s=1.0),
                on_event=lambda k, **f: events.append((k, f)))
    decisions = user_loop(m, w, LingeringPolicy(w, stop_at=0.25, linger_s=1.0))
    assert [s.outcome for s in m.episode.subgoals] == ["success"]
    assert [f["ok"] for k, f in events if k == "rest_check"] == [True], "judged where the block is, not at x = 0"
    assert decisions[-1].kind is DecisionKind.TASK_DONE
