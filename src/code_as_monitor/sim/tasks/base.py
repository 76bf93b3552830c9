"""Task registry and base class.

A task is a :class:`TaskConfig` registered by id (``@TaskConfig.register("stack-in-order")``) plus
the :class:`Task` it builds. Hooks, in the order :func:`code_as_monitor.sim.env.make_env` calls them:
``load_scene(world)`` (create and register the named objects), ``reset(world)`` (randomise with
``world.rng``), then per control tick ``on_tick(world)`` (ground-truth consequence events), and
``evaluate(world) -> TaskResult`` at any time. ``default_plan()`` is the open-loop action list;
``disturbances()`` builds the disturbance wrappers from the config.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.registry import Choice, check_positive


def _norm(x: Any) -> Any:
    return tuple(x) if isinstance(x, (list, tuple)) else x


def _same(a: Any, b: Any) -> bool:
    """Equal, treating lists and tuples alike."""
    return bool(_norm(a) == _norm(b))


@dataclass
class TaskResult:
    """Outcome of :meth:`Task.evaluate`: ``success`` plus JSON-serialisable details."""

    success: bool
    reason: str
    info: dict[str, Any] = field(default_factory=dict)


@dataclass
class TaskConfig(Choice):
    """Base of every task config. ``time_limit``: seconds of sim time allowed (the paper's limit).

    ``instruction``: the instruction given to the agent (empty: the task's own). The goal parameters it asks
    for (a tower order, a count band, ...) are read from it by the instruction grammar
    (:func:`code_as_monitor.vlm.kb.goals.task_goal`) and set on the config, so the success check and the
    ground-truth log follow it; a parameter also given explicitly with another value is a ConfigError.
    """

    time_limit: float = 70.0
    instruction: str = ""

    task_class: ClassVar[type[Task]]

    def __post_init__(self) -> None:
        check_positive(type(self).__name__, "time_limit", self.time_limit)
        if self.instruction:
            self._apply_instruction()

    def scene_objects(self) -> list[str] | None:
        """The task's object names (what the agent will see), for grounding an instruction; None: infer them."""
        return None

    def _apply_instruction(self) -> None:
        from code_as_monitor.vlm.kb.goals import task_goal

        params = task_goal(type(self).name, self.instruction, self.scene_objects())
        defaults = {f.name: f.default for f in dataclasses.fields(self)}
        for key, value in params.items():
            current = getattr(self, key)
            if _same(current, defaults[key]) is False and _same(current, value) is False:
                raise ConfigError(f"{type(self).name}: {key}={current!r} contradicts the instruction "
                                  f"{self.instruction!r}, which asks for {key}={value!r}")
            setattr(self, key, value)

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

    def placed(self, world: Any, obj: str, target: str) -> tuple[bool, str] | None:
        """Does ``obj``, let go by a placing skill into ``target`` and now at rest, lie where the task needs it?
        ``(ok, reason)``; None: the task has no such test (:mod:`code_as_monitor.sim.placement` logs nothing)."""
        return None

    def default_plan(self) -> list[Action]:
        raise NotImplementedError

    def disturbances(self, seed: int = 0) -> list[Any]:
        """Disturbance objects configured for this task, seeded from ``seed`` (default: none)."""
        return []

    def action_noise(self, seed: int) -> Any:
        """The policy's action noise for an episode seeded ``seed`` (``sim.action_noise.ActionNoise``); exact by
        default (the RLBench-style tasks perturb their skills as a learned policy would)."""
        from code_as_monitor.sim.action_noise import NO_NOISE

        return NO_NOISE

    def camera_specs(self, width: int, height: int) -> list[Any] | None:
        """The task's own cameras (``sim.cameras.CameraSpec`` list) when the world config names none; None: the
        world's default views (front and top)."""
        return None

    def settle_after_plan(self) -> bool:
        """True when the open-loop episode ends once the plan is done (False: run to the time limit)."""
        return True
