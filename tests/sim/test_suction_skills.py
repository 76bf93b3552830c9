"""The suction primitives: a pick reaches contact wherever the block lies, and "on the table" finds free table."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")


def _run(env, action) -> None:
    env.policy.start(action)
    while not env.policy.done:
        env.policy.step()


def _base(policy):
    while hasattr(policy, "inner"):
        policy = policy.inner
    return policy


def test_pick_near_the_arm_base_attaches_the_block():
    """This scene's blue block lies close to the arm's base, where the inverse kinematics leaves the tip about
    9 mm above the commanded height (beyond the cup's 6 mm contact tolerance): the pick must descend on until
    it touches the block."""
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=1213652141, disturbed=False) as env:
        assert np.linalg.norm(env.world.position("blue_block")[:2]) < 0.40  # near the base (at the origin)
        _run(env, env.plan[2])  # pick blue
        assert env.world.name_of(env.world.robot.ee.holding) == "blue_block"
        assert env.world.position("blue_block")[2] > 0.1


def test_put_down_on_the_table_goes_to_free_table():
    from code_as_monitor.core.constraints import Action
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=3, disturbed=False) as env:
        _run(env, env.plan[0])  # green on the cup
        _run(env, Action("place_on", {"obj": "green_block", "target": "red_block"}))
        _run(env, env.plan[2])  # blue on the cup, right above ...
        spot = _base(env.policy).free_table_xy("blue_block")
        for name in ("red_block", "green_block"):
            assert np.linalg.norm(spot - env.world.position(name)[:2]) >= 0.10
        _run(env, Action("place_on", {"obj": "blue_block", "target": "table"}))
        blue = env.world.position("blue_block")
        assert blue[2] < 0.03 and np.linalg.norm(blue[:2] - spot) < 0.02
        assert env.world.robot.ee.holding is None


# the arm and blocks when stack q=3 1709376404 (``depth``, 25748e7) began its first pick that missed (t = 25.1 s):
# joint 7 at its 170-degree limit; arm joints (7,) radians; block centre (x, y) metres and yaw radians
WOUND_Q = [1.5953, 0.8848, -1.4791, -2.4055, 1.1227, 2.1129, 2.9671]
WOUND_SCENE = {"red_block": ((0.4266, 0.0407), 1.0404), "green_block": ((0.5198, 0.1385), -1.3242),
               "blue_block": ((0.5829, 0.1882), -1.4932)}


def test_a_pick_with_the_wrist_on_its_limit_still_attaches_the_block():
    """Taking the block's equivalent yaw nearest the current one wound the last wrist joint one way over many
    re-grasps onto its limit; the solver then gave up the tip's position for the yaw and the cup came down 44 mm
    from the block, and every re-pick after it too (25 "not held" loops to the re-plan bound). From that
    episode's arm and blocks, the pick takes an equivalent yaw the wrist can reach, logs the turn, and holds the
    block."""
    import pybullet as pb

    from code_as_monitor.core.constraints import Action
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=0, disturbed=False) as env:
        world = env.world
        robot, c = world.robot, world.client
        for name, ((x, y), yaw) in WOUND_SCENE.items():
            pb.resetBasePositionAndOrientation(world.body_of(name), [x, y, 0.02],
                                               pb.getQuaternionFromEuler([0.0, 0.0, yaw]), physicsClientId=c)
        for j, q in enumerate(WOUND_Q):
            pb.resetJointState(robot.body, j, q, physicsClientId=c)
        robot.command(WOUND_Q)
        _base(env.policy).mover.sync()
        world.idle(0.1)
        _run(env, Action("pick", {"obj": "green_block"}))
        assert world.name_of(robot.ee.holding) == "green_block"
        assert world.position("green_block")[2] > 0.1
        assert [e["kind"] for e in world.events.events].count("wrist_turned") == 1
