"""The table composed from its own render (``sim.backdrop``) gives the same pixels as one render of the whole scene."""

from __future__ import annotations

import dataclasses

import numpy as np
import pybullet as pb
import pytest

from code_as_monitor.sim import WorldConfig, make_env
from code_as_monitor.sim.backdrop import Backdrop, compose, raw_images
from code_as_monitor.sim.cameras import camera_set
from code_as_monitor.sim.tasks import task_names
from code_as_monitor.sim.world import ASSETS, TABLE_POSITION, World


def test_compose_takes_the_nearer_pixel_and_gives_a_tie_to_the_scene() -> None:
    scene = (np.full((2, 3, 4), 10, np.uint8), np.array([[0.2, 0.5, 1.0], [0.7, 1.0, 0.4]]),
             np.array([[5, 6, -1], [7, -1, 8]], np.int32))
    table = (np.full((2, 3, 4), 99, np.uint8), np.array([[0.3, 0.5, 0.6], [0.6, 1.0, 1.0]]),
             np.array([[0, 0, 0], [0, -1, -1]], np.int32))
    rgba, z, seg = compose(scene, table)
    assert seg.tolist() == [[5, 6, 0], [0, -1, 8]]
    assert z.tolist() == [[0.2, 0.5, 0.6], [0.6, 1.0, 0.4]]
    assert rgba[:, :, 0].tolist() == [[10, 10, 99], [99, 10, 10]]


def _compare_along_episode(task: str, cameras: str | None = None, every: int = 40) -> tuple[int, int]:
    """(views compared, pixels that differ) between the world's composed frames and one render of the whole scene
    (the table made visible in the client), along the task's scripted episode."""
    cfg = WorldConfig()
    if cameras is not None:
        cfg = dataclasses.replace(cfg, cameras=camera_set(cameras, cfg.width, cfg.height))
    env = make_env(task, seed=1, world_config=cfg)
    w = env.world
    assert w.backdrop is not None
    table = w.body_of("table")
    hidden = list(pb.getVisualShapeData(table, physicsClientId=w.client)[0][7])
    assert hidden[3] == 0.0  # the client's own renders skip the table
    views = differ = 0

    def compare() -> None:
        nonlocal views, differ
        for cam in w.cameras:
            cam.follow_mount()
            composed = cam.images(cam._view)
            pb.changeVisualShape(table, -1, rgbaColor=[*hidden[:3], 1.0], physicsClientId=w.client)
            backdrop, cam.backdrop = cam.backdrop, None
            try:
                whole = cam.images(cam._view)
            finally:
                cam.backdrop = backdrop
                pb.changeVisualShape(table, -1, rgbaColor=hidden, physicsClientId=w.client)
            assert (whole[2] == 0).sum() > 0  # the table is in the view
            views += 1
            differ += int((composed[0] != whole[0]).any(axis=2).sum() + (composed[1] != whole[1]).sum()
                          + (composed[2] != whole[2]).sum())

    try:
        compare()
        for action in env.plan:
            env.policy.start(action)
            n = 0
            while not env.policy.done and n < 1500:
                env.policy.step()
                n += 1
                if n % every == 0:
                    compare()
        compare()
    finally:
        env.close()
    return views, differ


@pytest.mark.parametrize("task,cameras", [("stack-in-order", None), ("sweep-half", None),
                                          ("screw-bulb", None), ("rope-close-square", "shoulders")])
def test_composed_frames_equal_whole_scene_renders(task: str, cameras: str | None) -> None:
    """screw-bulb has RLBench's four views, one on the wrist (a new table render each frame)."""
    views, differ = _compare_along_episode(task, cameras)
    assert views >= 10 and differ == 0


@pytest.mark.slow
@pytest.mark.parametrize("task", task_names())
def test_composed_frames_equal_whole_scene_renders_every_task(task: str) -> None:
    views, differ = _compare_along_episode(task, every=25)
    assert views >= 4 and differ == 0


def test_a_fixed_view_renders_the_table_once_and_close_releases_the_client() -> None:
    w = World(WorldConfig(), seed=0)
    try:
        for _ in range(3):
            w.render()
        assert w.backdrop is not None and w.backdrop.renders == len(w.cameras)
        client = w.backdrop.client
    finally:
        w.close()
    assert w.backdrop.client == -1
    with pytest.raises(pb.error):
        pb.getNumBodies(physicsClientId=client)


def test_without_the_backdrop_the_client_draws_the_table() -> None:
    w = World(WorldConfig(backdrop=False), seed=0)
    try:
        assert w.backdrop is None
        assert pb.getVisualShapeData(w.body_of("table"), physicsClientId=w.client)[0][7][3] == 1.0
        cam = w.cameras[0]
        _, _, seg = raw_images(w.client, cam.spec.width, cam.spec.height, cam._view, cam._proj)
        assert (seg == 0).sum() > 1000
    finally:
        w.close()


def test_backdrop_labels_table_pixels_with_the_worlds_table_id() -> None:
    b = Backdrop(ASSETS / "table.urdf", TABLE_POSITION, seg_value=7)
    try:
        w = World(WorldConfig(backdrop=False), seed=0)
        cam = w.cameras[1]
        _, z, seg = b.images(cam.spec.width, cam.spec.height, cam._view, cam._proj)
        w.close()
        assert set(np.unique(seg).tolist()) <= {-1, 7} and (seg == 7).sum() > 1000
        assert (z[seg == -1] >= 1.0 - 1e-7).all()
    finally:
        b.close()
