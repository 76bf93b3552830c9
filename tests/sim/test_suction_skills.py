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
