"""Simulator tasks, registered on :class:`TaskConfig` by id. Importing this package registers them."""

from code_as_monitor.sim.tasks import (  # noqa: F401
    drag_stick,
    open_drawer,
    pour_tea,
    put_in_drawer,
    rope_close_square,
    screw_bulb,
    slot_pen,
    stack_in_order,
    stow_book,
    sweep_half,
    sweep_to_dustpan,
    turn_tap,
)
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult


def task_names() -> list[str]:
    """The registered task ids, sorted (this package registers every task when imported)."""
    return TaskConfig.choices()


__all__ = ["Task", "TaskConfig", "TaskResult", "task_names"]
