"""Elements painted while the robot hides their objects (issue 12 targets; the p = 0 CaM failure in RESULTS.md).

A simulator tower (green on red) with the arm holding the blue block above it, on the line of sight from the tower
to the front camera, so that the arm, its cup and the held block cover most of the tower in every default view (the
top view sees none of it). Perception: sim segmenter masks (with the robot's own mask), the painter's geometry (no
tracker). Ground truth: :mod:`code_as_monitor.bench.element_truth`. Target: points within 8 mm, or reported weak.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.bench.element_truth import element_errors, part_truth
from code_as_monitor.core import Constraint, ElementSpec, Observation, Phase, Subgoal
from code_as_monitor.painter import Painter
from code_as_monitor.painter.carry_over import key_of, known_from
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.robot import ARM_JOINTS

POINT_MAX = 0.008
TOWER = ("red_block", "green_block")
FRONT_EYE = np.array([1.15, 0.0, 0.65])  # the default front camera (sim.cameras)


def _subgoal() -> Subgoal:
    return Subgoal("look", [Constraint("look", "see", Phase.UPON, [ElementSpec(b, b) for b in TOWER])])


def _painter() -> Painter:
    return Painter(make_segmenter(SegmenterConfig.from_name("sim")))


def _tower(w) -> tuple[list[float], list[float]]:
    import pybullet as pb

    red, green = (w.objects[b].bodies[0] for b in TOWER)
    pos, orn = pb.getBasePositionAndOrientation(red, physicsClientId=w.client)
    pb.resetBasePositionAndOrientation(green, [pos[0], pos[1], pos[2] + 0.04], orn, physicsClientId=w.client)
    return list(pos), list(orn)


def _occlude(w, pos: list[float], orn: list[float], height: float) -> None:
    """The arm holds the blue block at ``height`` on the line from the tower to the front camera."""
    import pybullet as pb

    base = np.array([pos[0], pos[1], pos[2] + 0.03])
    d = (FRONT_EYE - base) / np.linalg.norm(FRONT_EYE - base)
    p = base + d * (height - base[2]) / d[2]
    for _ in range(10):
        for j, q in zip(ARM_JOINTS, w.robot.ik(p + np.array([0.0, 0.0, 0.02]), 0.0)):
            pb.resetJointState(w.robot.body, j, q, physicsClientId=w.client)
    blue = w.objects["blue_block"].bodies[0]
    pb.resetBasePositionAndOrientation(blue, p.tolist(), orn, physicsClientId=w.client)
    w.robot.ee.activate([blue])


def _errors(w, res) -> dict[str, float]:
    return {e.owner[0]: element_errors("point", e.points, part_truth(w, e.owner[0]))["point"] for e in res.elements}


@pytest.mark.parametrize("seed", [0, 1])
def test_the_robot_over_a_tower_is_reported_and_a_remembered_estimate_is_carried_over(seed: int) -> None:
    with make_env("stack-in-order", seed=seed, disturbed=False) as env:
        w = env.world
        pos, orn = _tower(w)
        clear: Observation = w.observe()
        before = _painter().paint(clear, _subgoal())
        assert all(e.support.robot_hidden == 0.0 for e in before.elements)
        known = {key_of(before.specs[e.id]): known_from(e, e.points, clear.t) for e in before.elements}
        # nothing hidden: remembered estimates change nothing
        again = _painter().paint(clear, _subgoal(), known=known)
        assert again.carried == [] and [e.points.tolist() for e in again.elements] == \
            [e.points.tolist() for e in before.elements]

        _occlude(w, pos, orn, 0.12)
        obs = w.observe()
        assert sum(int(v.mask_of("green_block").sum()) for v in obs.views.values()) < 60  # mostly hidden
        assert int(obs.views["top"].mask_of("green_block").sum()) == 0
        fresh = _painter().paint(obs, _subgoal())
        err = _errors(w, fresh)
        for e in fresh.elements:  # wrong, or reported weak (the robot hides it)
            assert err[e.owner[0]] <= POINT_MAX or (e.support.weak() and e.support.robot_hidden > 0.3), \
                (e.owner, err, e.support)
        carried = _painter().paint(obs, _subgoal(), known=known)
        assert not carried.missing and all(e.support.carried for e in carried.elements)
        assert [d.carried for d in carried.carried] == [True, True]
        # the unhidden estimate, exactly (how far that one is from the truth is the painter's own accuracy,
        # test_elements_on_sim), so within the point targets
        assert [e.points.tolist() for e in carried.elements] == [e.points.tolist() for e in before.elements]
        err = list(_errors(w, carried).values())
        assert max(err) <= POINT_MAX, np.round(1000 * np.array(err), 1)


def test_a_block_moved_while_the_robot_hides_it_is_not_carried_over() -> None:
    import pybullet as pb

    with make_env("stack-in-order", seed=0, disturbed=False) as env:
        w = env.world
        pos, orn = _tower(w)
        clear = w.observe()
        before = _painter().paint(clear, _subgoal())
        known = {key_of(before.specs[e.id]): known_from(e, e.points, clear.t) for e in before.elements}
        _occlude(w, pos, orn, 0.12)
        green = w.objects["green_block"].bodies[0]
        pb.resetBasePositionAndOrientation(green, [pos[0] + 0.0, pos[1] + 0.06, pos[2]], orn, physicsClientId=w.client)
        res = _painter().paint(w.observe(), _subgoal(), known=known)
        d = {x.name: x for x in res.carried}
        assert not d["green_block"].carried and "moved" in d["green_block"].reason, d["green_block"]
