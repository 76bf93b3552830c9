"""Fixtures for the geometry tests: the analytic synthetic scene (box, plate, rod; two cameras)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from code_as_monitor.core.observation import View
from code_as_monitor.geometry.synthetic import SyntheticScene, make_scene


@pytest.fixture(scope="session")
def scene() -> SyntheticScene:
    """The standard scene at 640x480 (renders are cached inside the scene)."""
    return make_scene()


@pytest.fixture(scope="session")
def noisy_views(scene: SyntheticScene) -> Callable[[int], list[View]]:
    """``noisy_views(seed)``: both views with 2 mm depth noise and 1 % outlier pixels inside the masks."""
    cache: dict[int, list[View]] = {}

    def get(seed: int) -> list[View]:
        if seed not in cache:
            cache[seed] = scene.views(seed=seed, noise_mm=2.0, outlier_frac=0.01)
        return cache[seed]

    return get
