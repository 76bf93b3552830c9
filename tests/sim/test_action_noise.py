"""The learned-policy analogue's noise: seeded, scaled, exact when off, bad values named."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.action_noise import NO_NOISE, ActionNoise


def test_exact_noise_draws_nothing() -> None:
    n = ActionNoise({"grasp_xy": 0.01}, scale=0.0, seed=3)
    assert not n.active
    assert n.normal("grasp_xy") == 0.0 and not n.offset("grasp_xy").any() and n.chance("wrong_target") is False
    assert n.draws == [] and not NO_NOISE.active


def test_same_seed_same_draws_other_seed_others() -> None:
    a, b, c = (ActionNoise({"grasp_xy": 0.01, "turn_rel": 0.1, "wrong_target": 0.5}, 1.0, s) for s in (4, 4, 5))
    for n in (a, b, c):
        n.offset("grasp_xy")
        n.normal("turn_rel")
        n.chance("wrong_target")
    assert a.draws == b.draws and a.draws != c.draws


def test_scale_multiplies_the_standard_deviation_and_probabilities() -> None:
    x1 = np.array([ActionNoise({"s": 0.01}, 1.0, s).normal("s") for s in range(400)])
    x3 = np.array([ActionNoise({"s": 0.01}, 3.0, s).normal("s") for s in range(400)])
    assert np.allclose(x3, 3 * x1)  # the same generator draws, scaled
    assert 0.008 < x1.std() < 0.012
    hits = sum(ActionNoise({"p": 0.25}, 2.0, s).chance("p") for s in range(400))
    assert 160 < hits < 240  # p = 0.5
    assert all(ActionNoise({"p": 0.9}, 5.0, s).chance("p") for s in range(20))  # clipped to 1


@pytest.mark.parametrize(("params", "scale", "bad"), [({}, -1.0, "scale"), ({}, float("nan"), "scale"),
                                                      ({"grasp_xy": -0.1}, 1.0, "grasp_xy")])
def test_bad_values_are_named(params, scale, bad) -> None:
    with pytest.raises(ConfigError, match=bad):
        ActionNoise(params, scale, 0)
