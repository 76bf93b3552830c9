"""Put Code-as-Monitor around your own policy, frame by frame.

    python examples/wrap_your_policy.py     # the demo's episode; needs the sim extra (it stands in for your robot)

Replace the two adapters with your robot's:

- ``YourRobot.observe()`` returns an ``Observation``: calibrated RGB-D views (``View(rgb, depth in
  metres, CameraModel(K, T_world_cam))``) and the end-effector pose (``RobotState``), on the robot's
  clock. See docs/robot.md for what has to be calibrated and how fast.
- ``YourPolicy`` exposes your controller as ``start(action)`` / ``step()`` / ``halt()`` / ``done``.

The monitor never drives anything: each frame it says whether to halt, which action to start next,
and whether the task is over. Here the robot is the simulator, so the example runs anywhere.
"""

from __future__ import annotations

from typing import Any

from code_as_monitor import Monitor, MonitorConfig
from code_as_monitor.core import Action, Observation


class YourPolicy:
    """Adapter from your controller to the policy protocol (here: the simulator's scripted skills)."""

    def __init__(self, controller: Any) -> None:
        self.controller = controller

    def start(self, action: Action) -> None:  # e.g. send a skill goal to your action server
        self.controller.start(action)

    def step(self) -> None:  # one control tick (a real robot's own loop may make this a no-op)
        self.controller.step()

    def halt(self) -> None:  # stop now and hold the pose
        self.controller.halt()

    @property
    def done(self) -> bool:  # the current action has finished by itself
        return self.controller.done


class YourRobot:
    """Adapter from your sensors to an Observation (here: the simulator's cameras and arm)."""

    def __init__(self, world: Any) -> None:
        self.world = world

    @property
    def t(self) -> float:
        return self.world.t

    def observe(self) -> Observation:
        return self.world.observe()


def main(tracker: str = "depth", size: tuple[int, int] = (640, 480), seed: int = 10) -> bool:
    from code_as_monitor.sim.env import make_env  # only the stand-in robot needs the simulator
    from code_as_monitor.sim.world import WorldConfig

    with make_env("stack-in-order", seed=seed, world_config=WorldConfig(width=size[0], height=size[1]), p=0.3) as env:
        robot, policy = YourRobot(env.world), YourPolicy(env.policy)
        config = MonitorConfig(backend="kb", segmenter="sim", tracker=tracker, frame_hz=10.0,
                               time_limit_s=env.task.config.time_limit)
        with Monitor.from_config(config) as monitor:
            monitor.start(env.instruction)
            while True:
                obs = robot.observe() if monitor.frame_due(robot.t, policy.done) else None
                if obs is not None:
                    d = monitor.step(obs, policy_done=policy.done)
                    if d.violations:  # a during check (kind halt) or an upon check when the policy finished
                        v = d.violations[0]
                        print(f"{d.t:5.1f} s  {d.kind.value}: {v.constraint_id}: {v.reason}")
                    if d.halt:
                        policy.halt()
                    if d.action is not None:
                        print(f"{d.t:5.1f} s  next: {d.subgoal.text} ({d.skill})")
                        policy.start(d.action)
                    if d.finished:
                        print(f"{d.t:5.1f} s  {d.kind.value}: {d.reason}")
                        break
                policy.step()
        success = env.evaluate().success
        print("task success:", success)
        return bool(success)


if __name__ == "__main__":
    main()
