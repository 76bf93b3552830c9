"""Success checkers on constructed states: a correct tower, a toppled one, zone counts, rope coverage."""

from __future__ import annotations

import numpy as np
import pybullet as pb
import pytest

from code_as_monitor.sim import make_env
from code_as_monitor.sim.tasks.rope_close_square import opening_coverage
from code_as_monitor.sim.tasks.stack_in_order import tower_in_order
from code_as_monitor.sim.tasks.sweep_half import count_in_zone

TOWER = {"red_block": [0.5, 0.0, 0.02], "green_block": [0.5, 0.0, 0.06], "blue_block": [0.5, 0.0, 0.10]}


def test_tower_in_order_pure():
    assert tower_in_order({k: np.array(v) for k, v in TOWER.items()})[0]
    swapped = dict(TOWER, green_block=TOWER["blue_block"], blue_block=TOWER["green_block"])
    assert not tower_in_order({k: np.array(v) for k, v in swapped.items()})[0]
    toppled = dict(TOWER, blue_block=[0.56, 0.0, 0.02])
    ok, reason = tower_in_order({k: np.array(v) for k, v in toppled.items()})
    assert not ok and "blue_block" in reason
    offset = dict(TOWER, green_block=[0.515, 0.0, 0.06], blue_block=[0.515, 0.0, 0.10])
    assert not tower_in_order({k: np.array(v) for k, v in offset.items()}, xy_tol=0.01)[0]
    assert tower_in_order({k: np.array(v) for k, v in offset.items()}, xy_tol=0.02)[0]


def _place(env, name, xyz):
    pb.resetBasePositionAndOrientation(env.world.body_of(name), xyz, [0, 0, 0, 1], physicsClientId=env.world.client)


def test_stack_evaluate_on_built_and_toppled_towers():
    with make_env("stack-in-order", seed=0) as env:
        for k, v in TOWER.items():
            _place(env, k, v)
        env.world.idle(1.0)
        assert env.evaluate().success
        _place(env, "blue_block", [0.5, 0.035, 0.101])  # hangs 3.5 cm over the edge: topples
        env.world.idle(1.5)
        res = env.evaluate()
        assert not res.success and "blue_block" in res.reason
        assert [e["obj"] for e in env.world.events.of_kind("tower_collapsed")] == ["blue_block"]


def test_zone_count_pure_and_on_world():
    assert count_in_zone(np.array([[0, 0], [0.079, -0.079], [0.081, 0], [1, 1]]), np.zeros(2), 0.08) == 2
    with make_env("sweep-half", seed=0) as env:
        c = env.world.position("zone")
        names = env.task.names
        for i, n in enumerate(names[:20]):
            _place(env, n, [c[0] - 0.07 + 0.035 * (i % 5), c[1] - 0.07 + 0.035 * (i // 5), 0.01])
        env.world.idle(0.2)
        res = env.evaluate()
        assert res.success and res.info["count"] == 20
        for i, n in enumerate(names[20:26]):
            _place(env, n, [c[0] - 0.05 + 0.02 * i, c[1] + 0.07, 0.01])
        env.world.idle(0.2)
        assert not env.evaluate().success and env.evaluate().info["count"] == 26


def test_rope_coverage_and_halt_requirement():
    a, b = np.array([0.0, 0.0]), np.array([0.2, 0.0])
    line = np.stack([np.linspace(-0.05, 0.25, 20), np.full(20, 0.01)], 1)
    assert opening_coverage(line, a, b, 0.025) == 1.0
    assert opening_coverage(line[:8], a, b, 0.025) < 0.9
    with make_env("rope-close-square", seed=0) as env:
        w = env.world
        targets = env.task.rope_targets(w, "rope", "square")  # a straight rope along the opening
        mid, u = targets.mean(0), (targets[-1] - targets[0]) / np.linalg.norm(targets[-1] - targets[0])
        line = mid + np.outer(np.arange(20) - 9.5, u) * env.task.config.spacing
        for name, xy in zip(env.task.beads, line):
            b_id = w.objects["rope"].parts[name][0]
            pb.resetBasePositionAndOrientation(b_id, [*xy, 0.008], [0, 0, 0, 1], physicsClientId=w.client)
        w.idle(0.5)
        res = env.evaluate()
        assert not res.success and "never halted" in res.reason
        env.policy.halt()
        assert env.evaluate().success
        assert env.world.events.of_kind("opening_enclosed")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_undisturbed_stack_open_loop_succeeds(seed):
    from code_as_monitor.sim.episode import run_open_loop

    res = run_open_loop("stack-in-order", seed=seed)
    assert res.success, res.reason
    assert res.t < 20.0
    assert not [e for e in res.events if e["kind"] in ("drop", "tower_collapsed", "placement_noise")]


@pytest.mark.slow
def test_open_loop_sweep_overshoots_and_rope_never_halts():
    from code_as_monitor.sim.episode import run_open_loop

    sweep = run_open_loop("sweep-half", seed=0)
    assert not sweep.success and sweep.info["count"] > 24 and sweep.t == pytest.approx(30.0)
    rope = run_open_loop("rope-close-square", seed=0)
    assert not rope.success and rope.info["halted_at"] is None
