"""Counterfactual rollouts leave the episode exactly where they found it, and see a predicted collapse."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.bench.counterfactual import rollout
from code_as_monitor.core.constraints import Action

pytest.importorskip("pybullet")

BLOCKS = ("red_block", "green_block", "blue_block")


def _positions(env) -> np.ndarray:
    return np.array([env.world.position(n) for n in BLOCKS])


def _run(env, action) -> None:
    env.policy.start(action)
    while not env.policy.done:
        env.policy.step()


def _offset_plan(env, off: float) -> list[Action]:
    red = env.world.position("red_block")
    g = [float(red[0]) + off, float(red[1])]
    return [Action("pick", {"obj": "green_block"}),
            Action("place_on", {"obj": "green_block", "target": "red_block", "xy": g}),
            Action("pick", {"obj": "blue_block"}),
            Action("place_on", {"obj": "blue_block", "target": "green_block", "xy": [g[0] + off, g[1]]})]


def test_rollout_restores_the_world_and_the_episode_continues_unchanged():
    from code_as_monitor.sim.env import make_env

    kw = dict(seed=5, q=3.0, p=0.3)
    with make_env("stack-in-order", **kw) as a, make_env("stack-in-order", **kw) as b:
        for env in (a, b):  # an alarm comes between actions or is followed by a halt
            _run(env, env.plan[0])
            _run(env, env.plan[1])
        t, n_ev, pos = a.world.t, len(a.world.events.events), _positions(a)
        cf = rollout(a, horizon_s=8.0)
        assert set(cf) >= {"confirmed", "event", "lead_s", "horizon_s", "success_at_end"}
        assert a.world.t == t and len(a.world.events.events) == n_ev
        assert np.allclose(_positions(a), pos, atol=1e-12)
        for env in (a, b):  # the rest of the plan draws the same noise and drops as without the rollout
            _run(env, env.plan[2])
            _run(env, env.plan[3])
        assert np.allclose(_positions(a), _positions(b), atol=1e-6)
        assert a.world.events.events == b.world.events.events


def test_rollout_sees_the_collapse_an_offset_block_leads_to():
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=2, disturbed=False) as env:
        env.plan = _offset_plan(env, 0.015)
        _run(env, env.plan[0])
        _run(env, env.plan[1])
        assert not env.world.events.of_kind("tower_collapsed")
        cf = rollout(env, horizon_s=15.0)
        assert not env.world.events.of_kind("tower_collapsed")
    assert cf["confirmed"] and cf["event"]["kind"] == "tower_collapsed" and cf["lead_s"] > 0
    assert cf["success_at_end"] is False


def test_rollout_does_not_confirm_a_safe_tower():
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=2, disturbed=False) as env:
        env.plan = _offset_plan(env, 0.0)
        _run(env, env.plan[0])
        _run(env, env.plan[1])
        cf = rollout(env, horizon_s=15.0)
    assert not cf["confirmed"] and cf["success_at_end"] is True


def test_no_new_disturbance_starts_in_a_rollout():
    """With drops certain (p = 1), the continuation of a centred tower still succeeds: the rollout asks what the
    state at the alarm leads to, not what a fresh drop would do; the episode's own drops are untouched."""
    from code_as_monitor.sim.env import make_env

    with make_env("stack-in-order", seed=2, p=1.0, q=3.0) as env:
        env.plan = _offset_plan(env, 0.0)
        env.world.disturbances_paused = True  # build the first level without drops or noise
        _run(env, env.plan[0])
        _run(env, env.plan[1])
        env.world.disturbances_paused = False
        n_drops = len(env.world.events.of_kind("drop"))
        cf = rollout(env, horizon_s=15.0)
        assert not env.world.disturbances_paused and len(env.world.events.of_kind("drop")) == n_drops
        _run(env, env.plan[2])  # the episode itself still drops
        _run(env, env.plan[3])
        assert len(env.world.events.of_kind("drop")) > n_drops
    assert cf["plan_ended"] and not cf["confirmed"] and cf["success_at_end"] is True


def _until(env, kind: str) -> None:
    """Play the plan until the ground-truth log has an event of ``kind``."""
    plan = list(env.plan)
    while not env.world.events.of_kind(kind):
        if env.policy.done:
            env.policy.start(plan.pop(0))
        env.policy.step()


def test_gripper_task_rollout_confirms_by_the_task_failing_when_the_plan_ends():
    """slot-pen (a): the pen is moved under the descending gripper; the open-loop plan closes on nothing and
    ends without a pen in the holder, so the proactive 'steady' prediction is confirmed at the plan's end."""
    from code_as_monitor.sim.env import make_env

    with make_env("slot-pen", seed=0, disturbance="a") as env:
        _until(env, "object_moved")
        t = env.world.t
        cf = rollout(env, horizon_s=15.0)
        assert env.world.t == t
    assert cf["plan_ended"] and cf["confirmed"] and cf["success_at_end"] is False
    assert cf["event"]["kind"] == "task_failed" and cf["lead_s"] > 0


def test_gripper_task_rollout_does_not_confirm_a_run_that_succeeds_or_does_not_end():
    from code_as_monitor.sim.env import make_env

    with make_env("slot-pen", seed=0) as env:
        _run(env, env.plan[0])
        ok = rollout(env, horizon_s=15.0)
        short = rollout(env, horizon_s=1.0)
    assert ok["plan_ended"] and not ok["confirmed"] and ok["success_at_end"] is True
    assert not short["plan_ended"] and not short["confirmed"]


def _play_until(env, t: float) -> object:
    """Play the plan until the world's clock reaches ``t``; returns the action in flight."""
    plan = list(env.plan)
    current = None
    while env.world.t < t - 1e-9:
        if env.policy.done:
            current = plan.pop(0)
            env.policy.start(current)
        env.policy.step()
    return current, plan


def _finish(env, current, plan) -> None:
    """As after an alarm: halt the action in flight, start it again, then play the rest of the plan."""
    env.policy.halt()
    env.policy.start(current)
    while plan or not env.policy.done:
        if env.policy.done:
            env.policy.start(plan.pop(0))
        env.policy.step()


def test_a_rollout_while_the_gripper_holds_the_pen_leaves_the_rest_of_the_episode_unchanged():
    """slot-pen (a), seed 1639494391, an alarm at t = 5 s while the fingers hold the pen: the episode after a
    rollout is the episode without it, to the bit (restoring PyBullet's state in place after the rollout moved
    the rest of this episode by 59 mm; the default rollout runs in a forked copy of the process)."""
    from code_as_monitor.sim.env import make_env

    kw = dict(seed=1639494391, disturbance="a")
    with make_env("slot-pen", **kw) as a, make_env("slot-pen", **kw) as b:
        runs = [_play_until(env, 5.0) for env in (a, b)]
        assert a.world.events.events == b.world.events.events
        cf = rollout(a, horizon_s=15.0)
        assert cf["plan_ended"]
        for env, (current, plan) in zip((a, b), runs):
            _finish(env, current, plan)
        assert a.world.events.events == b.world.events.events
        for name in a.world.object_poses():
            assert np.array_equal(a.world.pose(name), b.world.pose(name)), name


@pytest.mark.parametrize("task, kw, t", [("slot-pen", dict(seed=1639494391, disturbance="a"), 5.0),
                                         ("stack-in-order", dict(seed=5, q=3.0, p=0.3), 6.0)])
def test_a_forked_rollout_sees_what_an_in_place_rollout_sees(task: str, kw: dict, t: float):
    """The isolation changes nothing of the rollout's own verdict: both start from the same state."""
    from code_as_monitor.sim.env import make_env

    with make_env(task, **kw) as a, make_env(task, **kw) as b:
        for env in (a, b):
            _play_until(env, t)
        assert rollout(a, horizon_s=15.0, isolation="fork") == rollout(b, horizon_s=15.0, isolation="restore")


def test_an_unknown_isolation_is_named():
    with pytest.raises(ValueError, match="'thread'"):
        rollout(object(), isolation="thread")
