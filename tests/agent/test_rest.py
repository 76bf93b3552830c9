"""Re-planning after a failure waits for the scene to come to rest (``agent/rest.py``, ``Monitor``)."""

from __future__ import annotations

import numpy as np
import pytest
from loop_fakes import RULES, Coder, History, MovePolicy, Painter, Planner, Runtime, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.decision import DecisionKind
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.agent.rest import RestWait
from code_as_monitor.core import Observation, View
from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ConfigError

H, W = 48, 64
CAM = CameraModel.look_at("front", np.array([1.0, 0, 1]), np.zeros(3), W, H, 60.0)


def _depth(col: int | None) -> dict[str, np.ndarray]:
    """A table at 1 m with a 6x6 px object 5 cm nearer at column ``col`` (None: no object)."""
    d = np.full((H, W), 1.0, np.float32)
    if col is not None:
        d[20:26, col:col + 6] = 0.95
    return {"front": d}


def test_still_ignores_noise_and_missing_readings_and_sees_a_moving_object() -> None:
    rest = RestWait()
    rng = np.random.default_rng(0)
    a = _depth(10)
    b = {"front": a["front"] + rng.normal(0, 0.001, (H, W)).astype(np.float32)}  # 1 mm sensor noise
    b["front"][0:2, 0:3] += 0.05  # 6 flickering pixels: under the per-view floor
    b["front"][30:40, 30:40] = np.nan  # lost readings are not motion
    b["front"][40:44, 0:10] = 0.0
    assert rest.still(a, b)
    assert not rest.still(a, _depth(13)), "an object moved 3 px"
    assert rest.moved_pixels(a, _depth(13))["front"][0] == 2 * 3 * 6
    assert rest.still(a, {"front": np.ones((H // 2, W // 2), np.float32)}), "a resized view is not compared"
    assert rest.still(a, {"side": np.zeros((H, W), np.float32)}), "a view absent before is not compared"


@pytest.mark.parametrize("sigma", [0.0015, 0.002, 0.004])
def test_a_noisy_depth_camera_raises_the_tolerance_and_still_sees_motion(sigma: float) -> None:
    """Independent Gaussian depth noise in both frames of a static 320x240 view: at a fixed 5 mm tolerance 1.5 mm
    of it already moves more than the allowance; the tolerance estimated from the frames holds it still, and a
    block 4 cm proud of the table that slid 3 px is still seen (its edges change depth by 4 cm: above 5 x the
    difference's noise up to about 5.6 mm of noise)."""
    rng = np.random.default_rng(1)
    h, w = 240, 320

    def frame(col: int) -> dict[str, np.ndarray]:
        d = np.full((h, w), 1.0, np.float32)
        d[100:125, col:col + 25] = 0.96
        return {"front": d + rng.normal(0, sigma, (h, w)).astype(np.float32)}

    a = frame(100)
    fixed = RestWait(noise_k=0.0)
    assert not fixed.still(a, frame(100)), "at a fixed 5 mm the noise alone reads as motion"
    rest = RestWait()
    assert rest.still(a, frame(100))
    assert not rest.still(a, frame(103)), "a block 4 cm proud of the table slid 3 px"
    diff = np.abs(frame(100)["front"] - a["front"]).ravel()
    assert rest.tolerance(diff) == pytest.approx(5 * np.sqrt(2) * sigma, rel=0.1)


def test_noise_that_grows_with_distance_is_estimated_per_depth_band() -> None:
    """A view sloping from 0.5 to 1.5 m with noise growing as the square of the depth (2 mm at 1 m, 4.5 mm at
    1.5 m): one estimate for the whole view is too small for the far pixels; per depth band it holds the view still."""
    rng = np.random.default_rng(2)
    z = np.linspace(0.5, 1.5, 240)[:, None] * np.ones((1, 320))

    def frame() -> dict[str, np.ndarray]:
        return {"front": (z + rng.normal(0, 0.002, z.shape) * z**2).astype(np.float32)}

    rest = RestWait()
    assert all(rest.still(frame(), frame()) for _ in range(5))
    a, b = frame()["front"].ravel(), frame()["front"].ravel()
    assert not all(np.abs(b - a) <= rest.tolerance(np.abs(b - a))), "a single estimate lets far pixels move"


def test_noise_free_depth_keeps_the_tolerance() -> None:
    a, b = _depth(10)["front"], _depth(13)["front"]
    assert RestWait().tolerance(np.abs(b - a).ravel()) == RestWait().depth_tol


class FallingWorld(World):
    """The fake loop's world with one depth view: after ``t_fall`` an object slides 2 px per 0.1 s until ``t_rest``
    (``None``: it never stops)."""

    def __init__(self, t_drop: float, t_rest: float | None) -> None:
        super().__init__(t_drop=t_drop)
        self.t_rest = t_rest

    def col(self) -> int:
        if self.t < self.t_drop:
            return 5
        end = self.t if self.t_rest is None else min(self.t, self.t_rest)
        return 5 + int(20 * (end - self.t_drop)) % 50

    def observe(self) -> Observation:
        d = _depth(self.col())["front"]
        return Observation(t=self.t, views={"front": View(np.zeros((H, W, 3), np.uint8), d, CAM)},
                           objects=["block"])


def _run(world: World, rest: RestWait) -> tuple[list, list, Planner]:
    events: list = []
    planner = Planner([_subgoal("move block"), _subgoal("move block again", during=False)])
    checker = CodeChecker(Coder(), Painter(), Tracker(world), Runtime(RULES), History, AgentConfig())
    m = Monitor(planner, checker, rest=rest, on_event=lambda k, **f: events.append((k, f)))
    return user_loop(m, world, MovePolicy(world)), events, planner


def test_the_replan_waits_until_the_scene_stops_moving() -> None:
    """The block drops at 0.3 s and slides until 1.0 s: the halt carries no action; the re-planned subgoal starts
    on the first frame after two still frames (1.2 s), planned on that frame."""
    w = FallingWorld(t_drop=0.3, t_rest=1.0)
    decisions, events, planner = _run(w, RestWait(max_s=3.0))
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    assert halt.halt and halt.action is None and halt.subgoal is None and halt.ended.outcome == "violated"
    restart = next(d for d in decisions if d.t > halt.t and d.action is not None)
    assert restart.kind is DecisionKind.START and restart.subgoal.text == "move block again"
    assert restart.t == pytest.approx(1.2, abs=0.11)
    assert len(planner.calls) >= 2 and planner.calls[1][1].startswith("failure: attached")
    rest = [f for k, f in events if k == "rest"]
    assert len(rest) == 1 and rest[0]["at_rest"] and rest[0]["waited_s"] == pytest.approx(restart.t - halt.t)
    assert decisions[-1].kind is DecisionKind.TASK_DONE


def test_a_scene_that_never_rests_is_replanned_after_max_s() -> None:
    w = FallingWorld(t_drop=0.3, t_rest=None)
    decisions, events, _ = _run(w, RestWait(max_s=0.8))
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    restart = next(d for d in decisions if d.t > halt.t and d.action is not None)
    assert restart.t - halt.t == pytest.approx(0.8, abs=0.11)
    assert [f["at_rest"] for k, f in events if k == "rest"] == [False]


def test_without_the_wait_the_replan_is_on_the_halting_frame() -> None:
    w = FallingWorld(t_drop=0.3, t_rest=1.0)
    decisions, events, _ = _run(w, RestWait(max_s=0.0))
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    assert halt.action is not None and halt.subgoal.text == "move block again"
    assert not [k for k, _ in events if k == "rest"]


def test_frames_while_waiting_are_due_once_per_period() -> None:
    w = FallingWorld(t_drop=0.3, t_rest=1.0)
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History, AgentConfig())
    m = Monitor(Planner([_subgoal("move block"), _subgoal("again")]), checker, rest=RestWait(max_s=3.0))
    decisions = user_loop(m, w, MovePolicy(w), camera_hz=50.0)
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    restart = next(d for d in decisions if d.t > halt.t and d.action is not None)
    waiting = [d for d in decisions if halt.t < d.t < restart.t]
    assert waiting and all(d.kind is DecisionKind.CONTINUE for d in waiting)


def test_an_episode_stopped_while_waiting_for_rest_starts_the_next_one_planning() -> None:
    """Stopped from outside in the middle of a wait, then started again: the new episode's first frame is due
    at once and plans (the old wait's schedule does not carry over)."""
    w = FallingWorld(t_drop=0.3, t_rest=None)
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History, AgentConfig())
    m = Monitor(Planner([_subgoal("move block"), _subgoal("again")]), checker, rest=RestWait(max_s=3.0))
    m.start("move the block")
    policy = MovePolicy(w)
    while True:
        d = m.step(w.observe(), policy_done=policy.done)
        if d.halt:
            break
        if d.action is not None:
            policy.start(d.action)
        policy.step()
    assert not m.frame_due(w.t + 0.01)  # waiting: the next compared frame is a period away
    m.stop("operator stop", w.t)
    m.start("move the block")
    assert m.frame_due(w.t + 0.01)
    assert m.step(w.observe()).kind is DecisionKind.START


@pytest.mark.parametrize(("field", "value", "match"), [
    ("rest_max_s", -1.0, "rest_max_s"), ("rest_still_frames", 0, "rest_still_frames"),
    ("rest_depth_tol", 0.0, "rest_depth_tol"), ("rest_max_s", float("nan"), "rest_max_s"),
    ("rest_noise_k", -1.0, "rest_noise_k"),
])
def test_bad_rest_settings_name_the_field(field: str, value: float, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        AgentConfig(**{field: value})


def test_the_config_gives_a_wait_one_monitoring_period_apart() -> None:
    r = AgentConfig(frame_hz=20.0, rest_max_s=2.0, rest_still_frames=3).rest_wait()
    assert (r.max_s, r.period_s, r.still_frames, r.enabled) == (2.0, 0.05, 3, True)
    assert not AgentConfig(rest_max_s=0.0).rest_wait().enabled
    with pytest.raises(ConfigError, match="period_s"):
        RestWait(period_s=0.0)


def test_in_hand_needs_a_closed_gripper_and_an_object_at_the_tip() -> None:
    from code_as_monitor.agent.rest import in_hand
    from code_as_monitor.core.observation import RobotState

    pose = np.eye(4)
    pose[:3, 3] = [0.4, 0.0, 0.3]
    closed = RobotState(pose, gripper=1.0, ee_kind="gripper", ee_points={"tip": np.array([0.4, 0.0, 0.25])})
    handle = {3: np.array([[0.41, 0.01, 0.26]])}  # 1.7 cm from the tip
    owners = {3: "teapot", 7: "robot"}
    assert in_hand(closed, handle, owners)
    assert not in_hand(RobotState(pose, gripper=0.0, ee_points=closed.ee_points), handle, owners), "open: not held"
    assert not in_hand(closed, {3: np.array([[0.4, 0.0, 0.15]])}, owners), "10 cm below the tip: dropped"
    assert not in_hand(closed, {7: np.array([[0.4, 0.0, 0.25]])}, owners), "the robot's own element"
    assert not in_hand(closed, {3: np.full((1, 3), np.nan)}, owners)
    assert not in_hand(None, handle, owners)
    line = {3: np.array([[0.4, 0.08, 0.25], [0.4, -0.06, 0.25]])}  # a pen held near its middle
    assert in_hand(closed, line, owners)


def test_a_failure_with_an_object_in_hand_is_replanned_at_once() -> None:
    """A halted hand keeps what it holds: waiting could only let it get worse (tea running into a tipped pot's
    spout), so the re-plan comes with the halt, and the event says why."""
    w = FallingWorld(t_drop=0.3, t_rest=1.0)
    events: list = []
    checker = CodeChecker(Coder(), Painter(), Tracker(w), Runtime(RULES), History, AgentConfig())
    checker.holding = lambda obs: True
    m = Monitor(Planner([_subgoal("move block"), _subgoal("again", during=False)]), checker,
                rest=RestWait(max_s=3.0), on_event=lambda k, **f: events.append((k, f)))
    decisions = user_loop(m, w, MovePolicy(w))
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    assert halt.action is not None and halt.subgoal.text == "again"
    assert [f.get("skipped") for k, f in events if k == "rest"] == ["an object is in hand"]


def test_in_hand_over_time_needs_the_element_to_have_moved_with_the_tip() -> None:
    """Near the tip is not enough once the hand has travelled: the opening the fingers lower a pen into is near the
    tip but stayed put; the handle of a carried pot moved with it."""
    from code_as_monitor.agent.rest import in_hand
    from code_as_monitor.core.observation import RobotState

    tip_now, tip_then = np.array([0.4, 0.0, 0.25]), np.array([0.4, 0.1, 0.35])  # 14 cm of travel in the window
    robot = RobotState(np.eye(4), gripper=1.0, ee_kind="gripper", ee_points={"tip": tip_now})
    owners = {1: "pen_holder", 2: "teapot"}
    rim_now = np.array([[0.41, 0.0, 0.22]])
    assert not in_hand(robot, {1: rim_now}, owners, before=(tip_then, {1: rim_now[0]}))
    handle_then, handle_now = np.array([0.41, 0.11, 0.36]), np.array([[0.41, 0.01, 0.26]])
    assert in_hand(robot, {2: handle_now}, owners, before=(tip_then, {2: handle_then}))
    assert in_hand(robot, {1: rim_now}, owners, before=(tip_now + 0.005, {1: rim_now[0]})), "a hand at rest: nearness"
    assert not in_hand(robot, {2: handle_now}, owners, before=(tip_then, {})), "not seen a second ago: not judged held"


class SinkingWorld(FallingWorld):
    """An object whose depth grows 3 mm per 0.1 s from ``t_drop`` to ``t_rest``: under the 5 mm tolerance frame to
    frame, over it across a streak."""

    def observe(self) -> Observation:
        d = _depth(None)["front"]
        end = self.t if self.t_rest is None else min(self.t, self.t_rest)
        d[20:30, 20:30] = 0.9 + 0.03 * max(0.0, end - self.t_drop)
        return Observation(t=self.t, views={"front": View(np.zeros((H, W, 3), np.uint8), d, CAM)}, objects=["block"])


def test_a_slow_slide_is_not_taken_for_rest() -> None:
    w = SinkingWorld(t_drop=0.3, t_rest=1.2)
    decisions, events, _ = _run(w, RestWait(max_s=3.0))
    halt = next(d for d in decisions if d.kind is DecisionKind.HALT)
    restart = next(d for d in decisions if d.t > halt.t and d.action is not None)
    # frame to frame (3 mm each) it would have looked still from 0.5 s on; against the streak's first frame the
    # re-plan waits for the slide to end (the last 3 mm of it within the tolerance)
    assert 1.2 - 1e-6 <= restart.t <= 1.5, (halt.t, restart.t)
    assert [f["at_rest"] for k, f in events if k == "rest"] == [True]
