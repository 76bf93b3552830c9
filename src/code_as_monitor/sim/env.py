"""Build a ready-to-run simulated episode: world + task + (disturbed) scripted policy.

Usage from outside (the agent)::

    env = make_env("stack-in-order", seed=3, p=0.15)      # task config fields as keywords
    obs = env.world.observe()
    for action in env.plan:                                 # or actions from a planner
        env.policy.start(action)
        while not env.policy.done and env.world.t < env.task.config.time_limit:
            env.policy.step()
            if env.world.frame_due():
                obs = env.world.observe()
    result = env.evaluate()                                 # TaskResult(success, reason, info)
    env.close()
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from code_as_monitor.core.constraints import Action
from code_as_monitor.sim.disturbances import apply_disturbances
from code_as_monitor.sim.placement import PlacementWatch
from code_as_monitor.sim.policies import ScriptedPolicy
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult
from code_as_monitor.sim.world import World, WorldConfig

SETTLE_STEPS = 120  # physics steps to let the scene settle before the clock starts (not sim time)


@dataclass
class SimEnv:
    """One episode. ``policy`` is the disturbed scripted policy (implements core.policy.Policy)."""

    world: World
    task: Task
    policy: Any
    plan: list[Action]
    instruction: str

    def evaluate(self) -> TaskResult:
        return self.task.evaluate(self.world)

    def close(self) -> None:
        self.world.close()

    def __enter__(self) -> SimEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def make_task(name: str, **config: Any) -> Task:
    """The task registered as ``name`` built from config keywords (ConfigError on bad values)."""
    import code_as_monitor.sim.tasks  # noqa: F401  (registers the tasks)

    return TaskConfig.from_name(name, **config).make_task()


def make_env(name: str, seed: int = 0, world_config: WorldConfig | None = None, disturbed: bool = True,
             **config: Any) -> SimEnv:
    """Create the world for task ``name`` with ``seed``, load and randomise the scene, and build the
    scripted policy wrapped with the task's disturbances (unless ``disturbed=False``)."""
    import pybullet as pb

    task = make_task(name, **config)
    wc = world_config or WorldConfig()
    if wc.cameras is None:  # the task's own views (RLBench's four), else the world's default two
        specs = task.camera_specs(wc.width, wc.height)
        if specs is not None:
            wc = dataclasses.replace(wc, cameras=specs)
    world = World(wc, seed=seed, ee=task.ee_kind)
    try:
        task.load_scene(world)
        task.reset(world)
        for _ in range(SETTLE_STEPS):
            pb.stepSimulation(physicsClientId=world.client)
        world.tick_hooks.append(task.on_tick)
        world.tick_hooks.append(PlacementWatch(task))
        policy: Any = ScriptedPolicy(world, task)
        if disturbed:
            policy = apply_disturbances(world, policy, task.disturbances(seed))
    except BaseException:
        world.close()
        raise
    return SimEnv(world, task, policy, task.default_plan(), task.config.instruction or task.instruction)
