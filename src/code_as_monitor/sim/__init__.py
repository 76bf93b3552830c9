"""sim layer: PyBullet tabletop world, Panda + suction/spatula, cameras, tasks, disturbances,
scripted open-loop policies and the ground-truth event log.

Entry points: :func:`make_env` (world + task + disturbed policy for one seed),
:func:`code_as_monitor.sim.episode.run_open_loop` (a whole open-loop episode), :func:`task_names`.
Importing this package imports pybullet, quietly (without its "build time" banner; see
``sim.quiet_import``): every submodule's own ``import pybullet`` then finds it imported.
"""

from code_as_monitor.sim.quiet_import import pybullet as _quiet_pybullet

_quiet_pybullet()

from code_as_monitor.sim.env import SimEnv, make_env, make_task  # noqa: E402  (after the quiet import)
from code_as_monitor.sim.events import EventLog  # noqa: E402  (after the quiet import)
from code_as_monitor.sim.tasks import Task, TaskConfig, TaskResult, task_names  # noqa: E402  (after the quiet import)
from code_as_monitor.sim.world import World, WorldConfig  # noqa: E402  (after the quiet import)

__all__ = ["EventLog", "SimEnv", "Task", "TaskConfig", "TaskResult", "World", "WorldConfig", "make_env",
           "make_task", "task_names"]
