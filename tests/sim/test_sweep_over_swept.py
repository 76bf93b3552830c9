"""``over_swept``: logged once, the first time the zone holds more blocks than the task's success band accepts."""

from __future__ import annotations

import pybullet as pb
import pytest

from code_as_monitor.sim.env import make_env


def _place(env, name, xy) -> None:
    pb.resetBasePositionAndOrientation(env.world.body_of(name), [*xy, 0.01], [0, 0, 0, 1],
                                       physicsClientId=env.world.client)


def _grid(env, k: int) -> list:
    """The ``k``-th of 25 spots on a 5 x 5 grid inside the zone (3.5 cm apart)."""
    c = env.world.position("zone")
    return [c[0] - 0.07 + 0.035 * (k % 5), c[1] - 0.07 + 0.035 * (k // 5)]


def _over(env) -> list[dict]:
    return env.world.events.of_kind("over_swept")


@pytest.mark.parametrize("upper", [24, 10])
def test_over_swept_is_logged_when_the_count_first_exceeds_the_task_bound(upper):
    cfg = {} if upper == 24 else {"min_in_zone": 8, "max_in_zone": upper}
    with make_env("sweep-half", seed=0, **cfg) as env:
        names = env.task.names
        for k in range(upper):
            _place(env, names[k], _grid(env, k))
        env.world.idle(0.2)
        assert env.evaluate().success and _over(env) == []  # at the bound: accepted, nothing logged
        _place(env, names[upper], _grid(env, upper))
        env.world.idle(0.2)
        assert not env.evaluate().success
        (e,) = _over(env)
        counts = [z for z in env.world.events.of_kind("zone_count") if z["count"] == upper + 1]
        assert e["t"] == counts[0]["t"]  # the same tick the count first exceeded the bound
        assert e["count"] == upper + 1 and e["band"] == [env.task.config.min_in_zone, upper]
        assert e["obj"] == "zone" and set(e["objects"]) == {"zone", *names[:upper + 1]}
        # more blocks, one taken out and put back: still the one event
        _place(env, names[upper + 1], _grid(env, upper + 1))
        env.world.idle(0.2)
        _place(env, names[0], [env.world.position("zone")[0] + 0.3, env.world.position("zone")[1]])
        env.world.idle(0.2)
        _place(env, names[0], _grid(env, 0))
        env.world.idle(0.2)
        assert len(_over(env)) == 1


def test_reset_rearms_the_event():
    with make_env("sweep-half", seed=0) as env:
        for k, n in enumerate(env.task.names[:25]):
            _place(env, n, _grid(env, k))
        env.world.idle(0.2)
        assert len(_over(env)) == 1
        env.task.reset(env.world)
        assert env.task._over_swept is False and env.task.count(env.world) == 0
