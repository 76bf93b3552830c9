"""vqa-standin (a stand-in, not a VLM) on the RLBench-style tasks: yes/no from one simulator front image.

States are constructed in the simulator (dirt moved into the pan, a tap's lever turned on its joint, the cube
moved onto the target); the ground truth of each case is the simulator's state, the stand-in sees only the
rendered RGB of the front view, its camera and the robot's own points. A constraint of another task family
gets no answer from these rules.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.baselines.vqa_standin import VQAStandin
from code_as_monitor.baselines.vqa_standin_gripper import Gripper
from code_as_monitor.baselines.vqa_standin_rlbench import RLBenchRules
from code_as_monitor.core.constraints import Constraint
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig
from code_as_monitor.vlm.kb.families import drag, dustpan, pen, tap


def _by_key(constraints: list[dict]) -> dict[str, Constraint]:
    return {c["id"].split("_")[0]: Constraint.from_dict(c) for c in constraints}


def _ask(c: Constraint, env) -> bool:
    return VQAStandin().answer(c, env.world.observe(eager=True)).yes


def _move(world, name: str, xyz) -> None:
    import pybullet as pb

    b = world.body_of(name)
    _, orn = pb.getBasePositionAndOrientation(b, physicsClientId=world.client)
    pb.resetBasePositionAndOrientation(b, [float(v) for v in xyz], orn, physicsClientId=world.client)


@pytest.mark.parametrize("seed", [0, 1])
def test_dirt_in_the_pan(seed: int) -> None:
    with make_env("sweep-to-dustpan", seed=seed, noise=0.0, world_config=WorldConfig()) as env:
        goal = dustpan.FAMILY.understand(_parse("sweep the dirt into the dustpan"), env.world.objects)
        c = next(v for k, v in _by_key(dustpan.sweep(goal)).items() if k == "inpan")
        assert not _ask(c, env)  # the heap lies beside the pan
        centre = env.world.pose("dustpan/pan")[:3, 3]
        for i, name in enumerate(env.task.dirt_names):
            _move(env.world, name, centre + np.array([0.012 * (i - 2), 0.0, 0.015]))
        assert _ask(c, env)


@pytest.mark.parametrize("side", ["left", "right"])
def test_a_turned_lever_lies_sideways(side: str) -> None:
    import pybullet as pb

    with make_env("turn-tap", seed=0, noise=0.0, instruction=f"turn the {side} tap") as env:
        goal = tap.FAMILY.understand(_parse(f"turn the {side} tap"), env.world.objects)
        c, other = _by_key(tap.turn(goal))["turned"], _by_key(tap.turn(goal))["otherstill"]
        assert not _ask(c, env) and _ask(other, env)
        part = f"{side}_handle"
        pb.resetJointState(env.world.body_of("tap"), env.task.joints[part], env.task.turn_sign(part) * np.pi / 2,
                           0.0, physicsClientId=env.world.client)
        assert _ask(c, env)
        assert _ask(other, env)  # the named lever turned: the other one still looks closed


def test_cube_on_the_target() -> None:
    with make_env("drag-stick", seed=0, noise=0.0) as env:
        goal = drag.FAMILY.understand(_parse("use the stick to drag the cube onto the red target"), env.world.objects)
        c = _by_key(drag.drag(goal))["ontarget"]
        assert not _ask(c, env)
        _move(env.world, "cube", env.world.pose("target")[:3, 3] + [0.0, 0.0, 0.02])
        assert _ask(c, env)


def test_other_families_are_not_answered_here() -> None:
    c = Constraint.from_dict(pen.grasp("pen")[0])  # a pen's "steady": the gripper-task rules answer it
    assert RLBenchRules().answer(c.id.split("_")[0], c, None, Gripper(None, 0.0, 0.0)) is None  # type: ignore[arg-type]


def _parse(text: str):
    from code_as_monitor.vlm.grammar import parse

    return parse(text)
