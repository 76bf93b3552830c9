"""The RLBench-style tasks: scene contract (parts, seg labels, real joints, four cameras), success checkers on
constructed states, constructed policy mistakes logged as ground truth and failing the task, the exact oracle
succeeding (slow), and the noisy policy's failures all carrying a ground-truth event (slow)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.episode import run_open_loop
from code_as_monitor.sim.tasks.drag_stick import on_target
from code_as_monitor.sim.tasks.put_in_drawer import in_tray
from code_as_monitor.sim.tasks.sweep_to_dustpan import dirt_in_pan
from code_as_monitor.sim.world import WorldConfig

PARTS = {
    "put-in-drawer": ["drawer_cabinet/frame", "drawer_cabinet/drawer", "drawer_cabinet/handle", "block/body"],
    "screw-bulb": ["lamp/base", "lamp/socket", "lamp/bulb"],
    "turn-tap": ["tap/body", "tap/left_handle", "tap/right_handle"],
    "drag-stick": ["stick/shaft", "stick/grip", "cube/body", "target/surface"],
    "sweep-to-dustpan": ["broom/handle", "broom/head", "dustpan/pan", "dustpan/walls", "dirt_0"],
}
TASKS = list(PARTS)


class FixedNoise:
    """A constructed learned-policy mistake: named decisions get fixed values, every other one is exact."""

    active = True

    def __init__(self, **values: Any) -> None:
        self.values = values

    def normal(self, name: str) -> float:
        return float(self.values.get(name, 0.0))

    def offset(self, name: str, dims: int = 2) -> np.ndarray:
        return np.asarray(self.values.get(name, np.zeros(dims)), float)

    def chance(self, name: str) -> bool:
        return bool(self.values.get(name, False))


def _play(env: Any) -> None:
    w, pol = env.world, env.policy
    for a in env.plan:
        pol.start(a)
        while not pol.done and w.t < env.task.config.time_limit:
            pol.step()
    w.idle(1.0)


@pytest.mark.parametrize("task", TASKS)
def test_scene_parts_seg_labels_and_four_cameras(task: str) -> None:
    with make_env(task, seed=2, world_config=WorldConfig(width=96, height=72)) as env:
        obs = env.world.observe()
        assert set(obs.views) == {"front", "left_shoulder", "right_shoulder", "wrist"}
        for name in PARTS[task]:
            assert name in obs.object_poses, name
            obj, _, part = name.partition("/")
            seen = sum(int(v.mask_of(obj, part).sum()) for v in obs.views.values())
            assert seen > 0, name  # each part is its own segmentation id, seen by some camera
        assert env.task.ee_kind == "gripper" and env.policy.noise.active  # the learned-policy analogue is on
        assert not env.evaluate().success  # nothing is done at the start


def test_articulated_parts_are_real_joints() -> None:
    import pybullet as pb

    for task, obj, n_movable in (("turn-tap", "tap", 2), ("screw-bulb", "lamp", 2), ("put-in-drawer",
                                                                                        "drawer_cabinet", 1)):
        with make_env(task, seed=0) as env:
            b, c = env.world.body_of(obj), env.world.client
            kinds = [pb.getJointInfo(b, j, physicsClientId=c)[2] for j in range(pb.getNumJoints(b, physicsClientId=c))]
            assert sum(k != pb.JOINT_FIXED for k in kinds) == n_movable, task


def test_success_checkers_on_constructed_states() -> None:
    assert in_tray([-0.1, 0.0, -0.04]) and not in_tray([0.02, 0.0, -0.04]) and not in_tray([-0.1, 0.0, 0.01])
    T = np.eye(4)
    T[:3, 3] = [0.4, 0.1, 0.0]
    assert on_target([0.44, 0.14], T) and not on_target([0.46, 0.1], T)
    T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # turned 90 degrees: x out of the opening is world +y
    pts = np.array([[0.4, 0.1, 0.01], [0.4, 0.16, 0.01], [0.4, 0.1, 0.05], [0.5, 0.1, 0.01]])
    assert dirt_in_pan(pts, T).tolist() == [True, True, False, False]


@pytest.mark.parametrize(("task", "mistake", "what"), [
    ("put-in-drawer", {"pull_rel": -0.8}, "pull_short"),
    ("screw-bulb", {"turn_rel": -0.5}, "screw_short"),
    ("turn-tap", {"wrong_target": True}, "wrong_target"),
    ("drag-stick", {"grasp_xy": [0.0, 0.0], "drag_rel": -0.6}, "cube_off_target"),
    ("sweep-to-dustpan", {"sweep_rel": -0.7}, "dirt_left"),
])
def test_a_policy_mistake_is_ground_truth_and_fails_the_task(task: str, mistake: dict, what: str) -> None:
    with make_env(task, seed=1) as env:
        env.policy.noise = FixedNoise(**mistake)
        _play(env)
        fails = env.world.events.of_kind("policy_failure")
        assert [e["what"] for e in fails] == [what]
        assert not env.evaluate().success


def test_a_grasp_that_misses_is_logged_when_the_jaws_close() -> None:
    with make_env("drag-stick", seed=1) as env:
        env.policy.noise = FixedNoise(grasp_xy=[0.0, 0.09])
        env.policy.start(env.plan[0])
        while not env.policy.done:
            env.policy.step()
        (ev,) = env.world.events.of_kind("policy_failure")
        close = env.world.events.of_kind("gripper_close")[-1]
        assert ev["what"] == "grasp_missed" and ev["obj"] == "stick" and 0.0 <= ev["t"] - close["t"] <= 0.15


def test_noise_scale_is_validated() -> None:
    with pytest.raises(ConfigError, match="noise"):
        make_env("screw-bulb", noise=-1)
    with pytest.raises(ConfigError, match="side"):
        make_env("turn-tap", side="middle")


@pytest.mark.slow
@pytest.mark.parametrize("task", [*TASKS, "open-drawer"])
def test_the_exact_oracle_succeeds(task: str) -> None:
    for seed in range(3):
        res = run_open_loop(task, seed=seed, noise=0.0)
        assert res.success, (seed, res.reason)
        assert not [e for e in res.events if e["kind"] == "policy_failure"]


@pytest.mark.slow
@pytest.mark.parametrize("task", TASKS)
def test_noisy_failures_carry_ground_truth(task: str) -> None:
    """Scaled-up noise (x3): some episodes fail, and every failed one has a policy_failure event."""
    fails = 0
    for seed in range(8):
        res = run_open_loop(task, seed=seed, noise=3.0)
        events = [e for e in res.events if e["kind"] == "policy_failure"]
        if not res.success:
            fails += 1
            assert events, (seed, res.reason)
    assert fails >= 1


@pytest.mark.parametrize(("task", "family", "kind"), [("screw-bulb", "bulb", "bulbjaw"),
                                                      ("turn-tap", "tap", "lever_jaw")])
def test_the_jaws_read_closed_on_the_part_as_the_kb_expects(task: str, family: str, kind: str) -> None:
    """The jaw opening (proprioception) after the grasp is what the part's own width gives (a ball measured by its
    radius, not its bounding box), inside the kb's closed-on-it range; open, it is above that range."""
    from code_as_monitor.vlm.kb.registry import family as kb_family

    th = kb_family(family).thresholds[kind]

    def jaw(w: Any) -> float:
        f = w.robot_state().ee_points
        return float(np.linalg.norm(f["finger_left"] - f["finger_right"]))

    with make_env(task, seed=0, noise=0.0, world_config=WorldConfig(width=64, height=48)) as env:
        assert jaw(env.world) > th["max_jaw"]
        env.policy.start(env.plan[0])
        while not env.policy.done:
            env.policy.step()
        assert th["min_jaw"] <= jaw(env.world) <= th["max_jaw"]


@pytest.mark.parametrize(("angle", "turned", "ok"), [
    (45.0, 45.0, True), (45.0, 28.0, False), (45.0, 64.0, False), (90.0, 78.0, True), (90.0, 99.0, True),
])
def test_a_tap_turned_within_the_angle_asked_for_succeeds(angle: float, turned: float, ok: bool) -> None:
    """Success is the named handle turned open by the angle asked for, give or take 15 degrees (a quarter-turn: at
    least 75, its travel ends at 100)."""
    import pybullet as pb

    with make_env("turn-tap", seed=0, disturbed=False, angle=angle) as env:
        w, task = env.world, env.task
        body = w.body_of("tap")
        pb.resetJointState(body, task.joints["left_handle"], task.turn_sign("left_handle") * np.radians(turned),
                           physicsClientId=w.client)
        res = task.evaluate(w)
        assert res.success is ok, res.reason


@pytest.mark.slow
def test_the_exact_oracle_turns_the_angle_asked_for() -> None:
    for seed in range(2):
        res = run_open_loop("turn-tap", seed=seed, noise=0.0, instruction="turn the left tap 50 degrees")
        assert res.success, (seed, res.reason)
        assert abs(res.info["opened_deg"] - 50.0) <= 5.0, res.info
