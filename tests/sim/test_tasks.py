"""Every registered task resets and steps; determinism; bad actions and configs fail loudly."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError, SimError
from code_as_monitor.sim import make_env, task_names


def test_registry_has_the_three_tasks():
    assert set(task_names()) >= {"stack-in-order", "sweep-half", "rope-close-square"}


@pytest.mark.parametrize("name", task_names())
def test_task_resets_and_steps(name):
    with make_env(name, seed=0) as env:
        assert env.instruction and env.plan
        env.policy.start(env.plan[0])
        for _ in range(30):
            env.policy.step()
        obs = env.world.observe(render=False)
        assert obs.t == pytest.approx(30 * env.world.dt)
        for o in obs.objects:
            assert o in obs.object_poses
        res = env.evaluate()
        assert isinstance(res.success, bool) and res.reason


def _trajectory(name: str, seed: int, **kw) -> np.ndarray:
    with make_env(name, seed=seed, **kw) as env:
        env.policy.start(env.plan[0])
        out = []
        for _ in range(60):
            env.policy.step()
            out.append(np.concatenate([env.world.robot.tip(),
                                       *[env.world.position(n) for n in list(env.world.objects)[1:6]]]))
        return np.array(out)


@pytest.mark.parametrize("name", ["stack-in-order", "rope-close-square"])
def test_same_seed_same_trajectory(name):
    a, b = _trajectory(name, 4), _trajectory(name, 4)
    assert np.array_equal(a, b)
    assert not np.allclose(a, _trajectory(name, 5))


def test_unknown_skill_object_and_wrong_tool_raise():
    with make_env("stack-in-order", seed=0) as env:
        with pytest.raises(SimError, match="fly"):
            env.policy.start(Action("fly", {}))
        with pytest.raises(SimError, match="purple_block"):
            env.policy.start(Action("pick", {"obj": "purple_block"}))
        with pytest.raises(SimError, match="spatula"):
            env.policy.start(Action("push_into_region", {"region": "zone"}))
        with pytest.raises(SimError, match="target"):
            env.policy.start(Action("place_on", {"obj": "red_block"}))


def test_bad_config_values_are_named():
    with pytest.raises(ConfigError, match="p"):
        make_env("stack-in-order", p=1.5)
    with pytest.raises(ConfigError, match="q"):
        make_env("stack-in-order", q=-1)
    with pytest.raises(ConfigError, match="min_in_zone"):
        make_env("sweep-half", min_in_zone=30)
    with pytest.raises(ConfigError, match="nope"):
        make_env("stack-in-order", nope=1)


def test_halt_stops_motion_at_once():
    with make_env("stack-in-order", seed=0) as env:
        env.policy.start(env.plan[0])
        for _ in range(15):
            env.policy.step()
        env.policy.halt()
        assert env.policy.done and env.world.halted_at == pytest.approx(env.world.t)
        tip = env.world.robot.tip()
        for _ in range(20):
            env.policy.step()
        assert np.linalg.norm(env.world.robot.tip() - tip) < 0.02
        kinds = [e["kind"] for e in env.world.events]
        assert "action_halted" in kinds
        env.policy.start(Action("pick", {"obj": "green_block"}))  # a new action after a halt
        while not env.policy.done:
            env.policy.step()
        assert env.world.name_of(env.world.robot.ee.holding) == "green_block"
