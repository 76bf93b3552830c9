"""Task registry and base class.

A task is a :class:`TaskConfig` registered by id (``@TaskConfig.register("stack-in-order")``) plus
the :class:`Task` it builds. Hooks, in the order :func:`code_as_monitor.sim.env.make_env` calls them:
``load_scene(world)`` (create and register the named objects), ``reset(world)`` (randomise with
``world.rng``), then per control tick ``on_tick(world)`` (ground-truth consequence events), and
``evaluate(world) -> TaskResult`` at any time. ``default_plan()`` is the open-loop action list;
``disturbances()`` builds the disturbance wrappers from the config.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.registry import Choice, check_positive


@dataclass
class TaskResult:
    """Outcome of :meth:`Task.evaluate`: ``success`` plus JSON-serialisable details."""

    success: bool
    reason: str
    info: dict[str, Any] = field(default_factory=dict)


@dataclass
class TaskConfig(Choice):
    """Base of every task config. ``time_limit``: seconds of sim time allowed (the paper's limit)."""

    time_limit: float = 70.0

    task_class: ClassVar[type[Task]]

    def __post_init__(self) -> None:
        check_positive(type(self).__name__, "time_limit", self.time_limit)

    def make_task(self) -> Task:
        return type(self).task_class(self)


class Task:
    """Base task. Subclasses set ``ee_kind`` and ``instruction`` and implement the hooks."""

    ee_kind: ClassVar[str] = "suction"
    instruction: ClassVar[str] = ""

    def __init__(self, config: TaskConfig) -> None:
        self.config = config

    @property
    def name(self) -> str:
        return type(self.config).name

    def load_scene(self, world: Any) -> None:
        raise NotImplementedError

    def reset(self, world: Any) -> None:
        """Randomise object poses with ``world.rng``."""

    def on_tick(self, world: Any) -> None:
        """Called after every control tick: log ground-truth consequence events."""

    def evaluate(self, world: Any) -> TaskResult:
        raise NotImplementedError

    def default_plan(self) -> list[Action]:
        raise NotImplementedError

    def disturbances(self, seed: int = 0) -> list[Any]:
        """Disturbance objects configured for this task, seeded from ``seed`` (default: none)."""
        return []

    def settle_after_plan(self) -> bool:
        """True when the open-loop episode ends once the plan is done (False: run to the time limit)."""
        return True


def task_names() -> list[str]:
    import code_as_monitor.sim.tasks  # noqa: F401  (registers the tasks)

    return TaskConfig.choices()
