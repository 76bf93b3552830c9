"""Drive a :class:`~code_as_monitor.agent.monitor.Monitor` around a synchronous world and policy.

For a world whose clock advances only when the policy steps (the simulator, or a robot driver that
blocks per control tick): step the policy until the monitor wants a frame, observe, hand the frame
over, do what the decision says. Frames are taken only when due, so an expensive renderer renders
no more than the monitoring rate asks for. A robot with its own real-time control loop calls
``Monitor.step`` from that loop instead (see ``examples/``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.agent.records import EpisodeLog
from code_as_monitor.core.observation import Observation
from code_as_monitor.core.policy import Policy


class Environment(Protocol):
    """What the driver needs from the world (a simulator or a robot driver)."""

    @property
    def t(self) -> float:
        """Current time, seconds (sim time in the simulator)."""
        ...

    def observe(self) -> Observation:
        """Render/grab one multi-view RGB-D frame."""
        ...


def drive(monitor: Monitor, instruction: str, env: Environment, policy: Policy,
          on_observation: Callable[[Observation, bool], None] | None = None) -> EpisodeLog:
    """Run one episode of ``instruction``: every frame the monitor takes goes through ``monitor.step``.

    ``on_observation(obs, policy_done)`` sees each frame handed to the monitor (a recorder writes
    them to a bag). Returns the monitor's episode log.
    """
    monitor.start(instruction)
    obs = env.observe()
    if on_observation is not None:
        on_observation(obs, policy.done)
    d = monitor.step(obs, policy_done=policy.done)
    while True:
        if d.halt:
            policy.halt()
        if d.action is not None:
            policy.start(d.action)
        if d.finished:
            return monitor.episode
        while True:
            policy.step()
            done = policy.done
            if monitor.frame_due(env.t, done):
                break
        obs = env.observe()
        if on_observation is not None:
            on_observation(obs, done)
        d = monitor.step(obs, policy_done=done)


__all__ = ["Environment", "drive"]
