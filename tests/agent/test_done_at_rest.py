"""Before the task is called complete, the monitor waits for rest, and if the scene moved meanwhile it judges the last
subgoal's upon checks again (``Monitor`` with ``check_done_at_rest``; ``CodeChecker.follow`` / ``at_rest``): a book that
passed "standing" while it was still tipping over, or a block that slid off after the halt, is a failure to re-plan on;
a scene that did not move is the one the completion was judged on."""

from __future__ import annotations

import numpy as np
import pytest
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.decision import DecisionKind
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.agent.rest import RestWait
from code_as_monitor.core import Observation, Subgoal, View
from code_as_monitor.core.camera import CameraModel

H, W = 48, 64
CAM = CameraModel.look_at("front", np.array([1.0, 0, 1]), np.zeros(3), W, H, 60.0)


class SlidingWorld(World):
    """The fake world with one depth view (the block a 6x6 px patch at a column that follows x). From ``t_slip`` the
    block, wherever the policy left it, slides back at 0.4 m/s to x = 0.1, or by ``dist`` metres (once; ``None``:
    never)."""

    def __init__(self, t_slip: float | None, dist: float | None = None) -> None:
        super().__init__()
        self.t_slip = t_slip
        self.x_slip: float | None = None
        self.dist = dist

    def observe(self) -> Observation:
        if self.t_slip is not None and self.t >= self.t_slip:
            if self.x_slip is None:
                self.x_slip = self.x
            end = 0.1 if self.dist is None else self.x_slip - self.dist
            self.x = max(end, self.x_slip - 0.4 * (self.t - self.t_slip))
            if self.x <= end:
                self.t_slip = None  # slid once; moved again by the policy from here
        d = np.full((H, W), 1.0, np.float32)
        col = 5 + round(100 * self.x)
        d[20:26, col:col + 6] = 0.95
        return Observation(t=self.t, views={"front": View(np.zeros((H, W, 3), np.uint8), d, CAM)}, objects=["block"])


class UntilDone(Planner):
    """Moves the block first; done after a success; moves it again after a failure."""

    def next_subgoal(self, instruction, images, objects, previous, feedback):
        self.calls.append((previous.text if previous else None, feedback))
        if feedback == "success":
            return Subgoal("done", done=True)
        return _subgoal("move block" if previous is None else "move block again", during=False)


def _run(world: World, cfg: AgentConfig | None = None, **kw) -> tuple[list, list, Planner]:
    events: list = []
    planner = UntilDone([])
    checker = CodeChecker(Coder(), Painter(), Tracker(world), Runtime(RULES), History, cfg or AgentConfig())
    m = Monitor(planner, checker, rest=RestWait(max_s=3.0), on_event=lambda k, **f: events.append((k, f)), **kw)
    return user_loop(m, world, MovePolicy(world)), events, planner


def test_a_block_that_slid_back_after_the_halt_is_replanned_on() -> None:
    w = SlidingWorld(t_slip=1.15)
    decisions, events, planner = _run(w)
    first = next(d for d in decisions if d.ended is not None and d.ended.outcome == "success")
    assert first.halt and first.action is None, "the planner said done: no action while the scene comes to rest"
    failed = next(d for d in decisions if d.kind is DecisionKind.SUBGOAL_FAILED)
    assert failed.ended.outcome == "reactive_failure" and "once the scene came to rest" in failed.ended.reason
    assert failed.ended.text == "move block" and failed.action is not None and failed.subgoal.text == "move block again"
    assert planner.calls[1] == ("move block", "success")
    assert planner.calls[2][0] == "move block" and planner.calls[2][1].startswith("failure: arrived")
    alarms = [f for k, f in events if k == "alarm"]
    assert [a["constraint_id"] for a in alarms] == ["arrived"] and alarms[0]["t"] == pytest.approx(failed.t)
    checks = [f for k, f in events if k == "rest_check"]
    assert [c["ok"] for c in checks] == [False], "judged again after the slide; the second claim, on a still scene, not"
    assert decisions[-1].kind is DecisionKind.TASK_DONE and w.x >= 0.2
    rests = [f for k, f in events if k == "done_rest"]
    assert len(rests) == 2 and rests[0]["at_rest"], "judged once the block had stopped, not at the slip"
    assert rests[0]["t"] >= 1.15 + (0.22 - 0.1) / 0.4


def test_a_scene_that_stays_put_is_complete_after_the_wait() -> None:
    w = SlidingWorld(t_slip=None)
    decisions, events, planner = _run(w)
    success = next(d for d in decisions if d.ended is not None and d.ended.outcome == "success")
    done = decisions[-1]
    assert done.kind is DecisionKind.TASK_DONE and done.t > success.t and len(planner.calls) == 2
    assert not [k for k, _ in events if k == "alarm"]
    assert [f["at_rest"] for k, f in events if k == "done_rest"] == [True]
    assert not [k for k, _ in events if k == "rest_check"], "nothing moved since the claim: the completion stands"
    assert [k for k, _ in events].index("task_complete_claimed") < [k for k, _ in events].index("task_complete")


def test_a_settling_of_centimetres_is_judged_again_unless_rest_motion_says_otherwise() -> None:
    """The block settles back 2.5 cm after the halt and the borderline check (x >= 0.2) now reads False: by default
    (``rest_motion`` 0) it is judged again at rest and re-planned on, as a rope whose bead slid 2.6 cm and opened the
    square must be; with ``rest_motion`` 3 cm (the gate until the twenty-fourth session) the completion stands, and a
    6 cm slide is still judged."""
    w = SlidingWorld(t_slip=1.15, dist=0.025)
    decisions, events, planner = _run(w)
    checks = [f for k, f in events if k == "rest_check"]
    assert checks[0]["judged"] and not checks[0]["ok"] and checks[0]["moved"] == pytest.approx(0.025, abs=0.003)
    assert any(d.kind is DecisionKind.SUBGOAL_FAILED for d in decisions)
    assert any(k == "alarm" for k, _ in events)

    w = SlidingWorld(t_slip=1.15, dist=0.025)
    decisions, events, planner = _run(w, AgentConfig(rest_motion=0.03))
    success = next(d for d in decisions if d.ended is not None and d.ended.outcome == "success")
    assert w.x < 0.2, "the slide would flip the check"
    assert decisions[-1].kind is DecisionKind.TASK_DONE and len(planner.calls) == 2
    assert not [k for k, _ in events if k == "alarm"]
    (check,) = [f for k, f in events if k == "rest_check"]
    assert check["ok"] and not check["judged"] and check["moved"] == pytest.approx(0.025, abs=0.003)
    assert decisions[-1].t > success.t
    w = SlidingWorld(t_slip=1.15, dist=0.06)
    decisions, events, _ = _run(w, AgentConfig(rest_motion=0.03))
    checks = [f for k, f in events if k == "rest_check"]
    assert checks[0]["judged"] and not checks[0]["ok"] and checks[0]["moved"] == pytest.approx(0.06, abs=0.003)
    assert any(d.kind is DecisionKind.SUBGOAL_FAILED for d in decisions)


def test_without_the_check_the_task_is_complete_on_the_planners_word() -> None:
    w = SlidingWorld(t_slip=1.15)
    decisions, events, _ = _run(w, check_done_at_rest=False)
    success = next(d for d in decisions if d.ended is not None and d.ended.outcome == "success")
    assert decisions[-1] is success and success.kind is DecisionKind.TASK_DONE
    assert not [k for k, _ in events if k in ("done_rest", "rest_check", "task_complete_claimed")]


class NoRestCheck:
    """A checker without ``follow`` / ``at_rest`` (as the baselines' are): it is taken at its word."""

    def __init__(self, inner: CodeChecker) -> None:
        self.inner = inner

    def start_episode(self, obs):
        self.inner.start_episode(obs)

    def begin(self, index, subgoal, obs, ctx):
        return self.inner.begin(index, subgoal, obs, ctx)

    def frame_due(self, t, policy_done):
        return self.inner.frame_due(t, policy_done)

    def frame(self, obs, policy_done, ctx):
        return self.inner.frame(obs, policy_done, ctx)

    def close(self):
        self.inner.close()


def test_a_checker_that_cannot_judge_at_rest_is_not_asked() -> None:
    w = SlidingWorld(t_slip=1.15)
    checker = NoRestCheck(CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History, AgentConfig()))
    m = Monitor(UntilDone([]), checker, rest=RestWait(max_s=3.0))
    decisions = user_loop(m, w, MovePolicy(w))
    success = next(d for d in decisions if d.ended is not None and d.ended.outcome == "success")
    assert decisions[-1] is success and success.kind is DecisionKind.TASK_DONE


def test_the_motion_gate_reads_measured_elements_order_free() -> None:
    """What counts as moved since the completion: not the robot's elements, not a part no view saw when painted (its
    whole object stood in), and not a line whose re-measured ends swapped."""
    from code_as_monitor.core import Element, ElementSupport
    from code_as_monitor.core.constraints import Constraint, Phase

    checker = CodeChecker(Coder(), Painter(), Tracker(World()), Runtime(RULES), History, AgentConfig())
    seen = ElementSupport(30, 2, 0.001, 0.01, (0.02, 0.02, 0.02))
    unseen = ElementSupport(300, 2, 0.003, 0.1, (0.2, 0.08, 0.01), part_seen=False)
    checker._elements = [
        Element.point(0, "gripper tip", np.zeros(3), ("robot", "tip")),
        Element.point(1, "rope bead_00", np.zeros(3), ("rope", "bead_00"), support=seen),
        Element.point(2, "rope bead_02", np.zeros(3), ("rope", "bead_02"), support=unseen),
        Element.line(3, "book spine", np.zeros(3), np.array([0, 0, 0.2]), ("book", "spine"), support=seen),
    ]
    checker._upon = [Constraint("c", "covered", Phase.UPON, [])]
    checker._uses = {"c": {0, 1, 2, 3}}
    judged = {0: np.zeros((1, 3)), 1: np.zeros((1, 3)), 2: np.zeros((1, 3)), 3: np.array([[0, 0, 0], [0, 0, 0.2]])}
    now = {0: np.array([[0.0, 0.0, 0.1]]), 1: np.array([[0.008, 0.0, 0.0]]), 2: np.array([[0.0, 0.06, 0.0]]),
           3: np.array([[0, 0, 0.2], [0, 0, 0.0]])}
    assert checker._moved_since(judged, now, set()) == pytest.approx(0.008)
    now[3] = np.array([[0, 0, 0], [0.0, 0.05, 0.19]])  # the spine tipped: its top end moved 5 cm
    assert checker._moved_since(judged, now, set()) == pytest.approx(np.hypot(0.05, 0.01))
    assert checker._moved_since(judged, now, {3}) == pytest.approx(0.008)
    assert checker._moved_since(None, now, set()) is None
