"""Tasks take their goal from the instruction: tower order and count band, success check and plan follow it."""

from __future__ import annotations

import pybullet as pb
import pytest

from code_as_monitor.core.errors import ConfigError, InstructionError
from code_as_monitor.sim import make_env
from code_as_monitor.sim.env import make_task

REVERSED = "stack red on top of green on top of blue"


def _place(env, name, xyz):
    pb.resetBasePositionAndOrientation(env.world.body_of(name), xyz, [0, 0, 0, 1], physicsClientId=env.world.client)


def _build(env, order):
    for level, name in enumerate(order):
        _place(env, name, [0.5, 0.0, 0.02 + 0.04 * level])
    env.world.idle(1.0)


def test_the_instruction_sets_the_tower_order_plan_and_success_check():
    with make_env("stack-in-order", seed=0, instruction=REVERSED) as env:
        assert env.instruction == REVERSED and env.task.config.order == ("blue_block", "green_block", "red_block")
        assert [(a.skill, a.args.get("obj"), a.args.get("target")) for a in env.plan] == [
            ("pick", "green_block", None), ("place_on", "green_block", "blue_block"),
            ("pick", "red_block", None), ("place_on", "red_block", "green_block")]
        _build(env, ("red_block", "green_block", "blue_block"))  # the default tower is now a failure
        assert not env.evaluate().success
        _build(env, ("blue_block", "green_block", "red_block"))
        assert env.evaluate().success


def test_a_two_block_tower_and_any_order():
    task = make_task("stack-in-order", instruction="put the blue block on the red block")
    assert task.config.order == ("red_block", "blue_block") and len(task.default_plan()) == 2
    with make_env("stack-in-order", seed=1, instruction="stack the blocks in any order") as env:
        assert env.task.config.any_order
        _build(env, ("green_block", "blue_block", "red_block"))
        assert env.evaluate().success


def test_the_instruction_sets_the_sweep_band():
    task = make_task("sweep-half", instruction="push 10 blocks into the zone")
    assert (task.config.min_in_zone, task.config.max_in_zone) == (9, 11)
    task = make_task("sweep-half", instruction="sweep all the blocks into the zone")
    assert (task.config.min_in_zone, task.config.max_in_zone) == (36, 40)
    default = make_task("sweep-half")
    assert default.instruction == "sweep half of the blocks into the zone"
    banded = make_task("sweep-half", min_in_zone=6, max_in_zone=10)
    again = make_task("sweep-half", instruction=banded.instruction)  # the text reads back to the same band
    assert (again.config.min_in_zone, again.config.max_in_zone) == (6, 10)


def test_parameters_without_an_instruction_give_an_instruction_that_reads_back():
    for order in (("blue_block", "red_block", "green_block"), ("green_block", "red_block")):
        task = make_task("stack-in-order", order=order)
        assert make_task("stack-in-order", instruction=task.instruction).config.order == order


@pytest.mark.parametrize("task,instruction,error,match", [
    ("stack-in-order", "push 10 blocks into the zone", InstructionError, "sweep-half instruction"),
    ("slot-pen", "stack red on green", InstructionError, "stack-in-order instruction"),
    ("stack-in-order", "stack the yellow block on the red block", InstructionError, "no yellow block"),
    ("sweep-half", "push 50 blocks into the zone", InstructionError, "40 blocks"),
])
def test_an_instruction_the_task_cannot_take_is_an_error_before_anything_runs(task, instruction, error, match):
    with pytest.raises(error, match=match):
        make_task(task, instruction=instruction)


def test_a_parameter_contradicting_the_instruction_is_a_config_error():
    with pytest.raises(ConfigError, match="contradicts the instruction"):
        make_task("stack-in-order", instruction=REVERSED, order=["red_block", "green_block"])
    with pytest.raises(ConfigError, match="two or three different blocks"):
        make_task("stack-in-order", order=["red_block", "red_block"])


def _open_to(env, metres):
    pb.resetJointState(env.world.body_of("drawer_cabinet"), env.task.joint, metres, 0.0,
                       physicsClientId=env.world.client)


def test_the_instruction_sets_how_far_the_drawer_opens():
    with make_env("open-drawer", seed=0, instruction="open the drawer 10 cm") as env:
        assert env.task.config.min_open == pytest.approx(0.10)
        assert env.plan[1].args["distance"] == pytest.approx(0.12)  # the open-loop pull follows it
        _open_to(env, 0.11)
        assert env.evaluate().success  # 11 cm: enough for 10 cm (not for the default 15 cm)
        _open_to(env, 0.08)
        assert not env.evaluate().success and "10.0 cm" in env.evaluate().reason
    assert make_task("open-drawer", instruction="open the drawer halfway").config.min_open == pytest.approx(0.125)
    assert make_task("open-drawer").config.min_open == pytest.approx(0.15)
    with pytest.raises(InstructionError, match="5 to 15 cm"):
        make_task("open-drawer", instruction="pull the drawer out 20 cm")
    with pytest.raises(ConfigError, match="contradicts the instruction"):
        make_task("open-drawer", instruction="open the drawer 10 cm", min_open=0.12)
    with pytest.raises(ConfigError, match="min_open"):
        make_task("open-drawer", min_open=0.3)


def test_the_instruction_sets_how_much_of_the_opening_the_rope_covers():
    assert make_task("rope-close-square", instruction="close half of the opening with the rope").config.min_coverage \
        == pytest.approx(0.5)
    assert make_task("rope-close-square",
                     instruction="cover the whole opening with the rope").config.min_coverage == pytest.approx(0.9)
    with pytest.raises(InstructionError, match="cannot promise"):
        make_task("rope-close-square", instruction="close at most half of the opening with the rope")


def test_drawer_and_rope_goals_without_an_instruction_give_one_that_reads_back():
    for min_open in (0.15, 0.1, 0.125, 0.06):
        task = make_task("open-drawer", min_open=min_open)
        assert make_task("open-drawer", instruction=task.instruction).config.min_open == pytest.approx(min_open)
    assert make_task("open-drawer").instruction == "open the drawer by pulling its handle"
    for cov in (0.9, 0.5, 0.8, 1.0):
        task = make_task("rope-close-square", min_coverage=cov)
        again = make_task("rope-close-square", instruction=task.instruction)
        assert again.config.min_coverage == pytest.approx(cov)
