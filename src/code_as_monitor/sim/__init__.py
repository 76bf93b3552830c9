"""sim layer: PyBullet tabletop world, Panda + suction/spatula, cameras, tasks, disturbances,
scripted open-loop policies and the ground-truth event log.

Entry points: :func:`make_env` (world + task + disturbed policy for one seed),
:func:`code_as_monitor.sim.episode.run_open_loop` (a whole open-loop episode), :func:`task_names`.
Importing this package imports pybullet.
"""

from code_as_monitor.sim.env import SimEnv, make_env, make_task
from code_as_monitor.sim.events import EventLog
from code_as_monitor.sim.tasks import Task, TaskConfig, TaskResult, task_names
from code_as_monitor.sim.world import World, WorldConfig

__all__ = ["EventLog", "SimEnv", "Task", "TaskConfig", "TaskResult", "World", "WorldConfig", "make_env",
           "make_task", "task_names"]
