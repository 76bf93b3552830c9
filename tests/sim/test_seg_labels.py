"""Every object a task lists is segmented: the painter finds any of them by name in every view."""

from __future__ import annotations

import pytest

pytest.importorskip("pybullet")

from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.tasks import task_names
from code_as_monitor.sim.world import WorldConfig


@pytest.mark.parametrize("task", task_names())
def test_every_listed_object_has_a_seg_label(task: str) -> None:
    with make_env(task, seed=0, world_config=WorldConfig(width=160, height=120)) as env:
        obs = env.world.observe()
    for view in obs.views.values():
        labelled = {obj for obj, _ in view.seg_labels.values()}
        missing = [name for name in obs.objects if name not in labelled]
        assert not missing, f"{task}: no seg label for {missing}"
