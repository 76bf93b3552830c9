"""Drop rate matches p per decision; placement noise bounded by q; both log ground-truth events."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.constraints import Action
from code_as_monitor.sim import make_env
from code_as_monitor.sim.disturbances import DisturbanceConfig, Drop, PlacementNoise


def test_registered_by_name():
    assert {"drop", "placement_noise"} <= set(DisturbanceConfig.choices())
    assert isinstance(DisturbanceConfig.from_name("drop", p=0.2).build(0), Drop)


@pytest.mark.parametrize("p", [0.15, 0.3])
def test_drop_rate_per_decision_matches_p(p):
    """Hold a block for a long time, re-attaching it after each drop; releases / decisions ~ p."""
    with make_env("stack-in-order", seed=0, p=p, drop_check_hz=10.0) as env:  # 10 Hz keeps the test short
        w = env.world
        drop = next(d for d in env.task.disturbances(0) if isinstance(d, Drop))
        w.tick_hooks = [h for h in w.tick_hooks if getattr(h, "__self__", None).__class__ is not Drop]
        drop.install(w)
        env.policy.start(Action("pick", {"obj": "green_block"}))
        while not env.policy.done:
            env.policy.step()
        ee = w.robot.ee
        body, rel_pos, rel_orn = ee.attachment()
        while drop.decisions < 600:
            env.policy.step()
            if ee.holding is None:
                ee.attach(body, rel_pos, rel_orn)
        rate = drop.releases / drop.decisions
        sigma = np.sqrt(p * (1 - p) / drop.decisions)
        assert abs(rate - p) < 4 * sigma, (rate, p)
        assert len(w.events.of_kind("drop")) == drop.releases
        # decisions come at drop_check_hz while holding
        assert drop.decisions == pytest.approx(w.t * env.task.config.drop_check_hz, rel=0.1)


def test_drop_zero_never_releases_and_logs_block_fell():
    with make_env("stack-in-order", seed=1, p=1.0) as env:
        env.policy.start(Action("pick", {"obj": "green_block"}))
        while not env.policy.done:
            env.policy.step()
        for _ in range(80):
            env.policy.step()
        ev = env.world.events
        assert ev.of_kind("drop")[0]["obj"] == "green_block"
        fell = ev.of_kind("block_fell")
        assert fell and fell[0]["obj"] == "green_block" and fell[0]["t"] > ev.of_kind("drop")[0]["t"]
        assert env.world.robot.ee.holding is None and env.world.robot.ee.active  # suction still "on"


def test_placement_noise_offsets_are_bounded_and_logged():
    noise = PlacementNoise(2.0, seed=0)
    r = np.linalg.norm([noise.offset() for _ in range(2000)], axis=1)
    assert r.max() <= 0.02 + 1e-12 and r.min() < 0.002 and abs(r.mean() - 0.01) < 0.001
    with make_env("stack-in-order", seed=0, q=3.0) as env:
        env.policy.start(env.plan[0])
        while not env.policy.done:
            env.policy.step()
        red = env.world.position("red_block")[:2]
        env.policy.start(env.plan[1])
        ev = env.world.events.of_kind("placement_noise")
        assert len(ev) == 1 and ev[0]["obj"] == "green_block"
        assert np.linalg.norm(ev[0]["offset"]) <= 0.03 + 1e-9
        assert np.allclose(env.policy.inner.action.args["xy"], red + np.array(ev[0]["offset"]))


def test_a_set_down_dropped_onto_the_table_lands_on_its_target():
    """A block dropped while being set down on the table (``place_on`` target ``table``) and resting on the table
    landed on its target, whatever spot of the table it comes to rest on; one dropped while being placed on a
    block and resting on the table did not."""
    with make_env("stack-in-order", seed=1, p=1.0) as env:
        env.policy.start(Action("pick", {"obj": "green_block"}))
        while not env.policy.done:
            env.policy.step()
        for _ in range(80):
            env.policy.step()
        first = env.world.events.of_kind("block_fell")[0]
        assert first["target"] == "" and not first["on_target"]  # dropped during the pick: no target
    for target, expected in (("table", True), ("red_block", False)):
        with make_env("stack-in-order", seed=1) as env:
            env.policy.start(Action("pick", {"obj": "green_block"}))
            while not env.policy.done:
                env.policy.step()
            w = env.world
            drop = Drop(1.0, check_hz=10.0, seed=0)  # from now on, every decision releases
            w.tick_hooks = [h for h in w.tick_hooks if getattr(h, "__self__", None).__class__ is not Drop]
            drop.install(w)
            env.policy.start(Action("place_on", {"obj": "green_block", "target": target}))
            for _ in range(200):
                env.policy.step()
                if env.world.events.of_kind("block_fell"):
                    break
            fell = env.world.events.of_kind("block_fell")
            assert fell, f"no block_fell while placing on {target}"
            assert fell[0]["target"] == target and fell[0]["on"] == "table"
            assert fell[0]["on_target"] is expected
