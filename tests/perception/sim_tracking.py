"""A helper of the simulator-backed tracker tests: run one scripted action and track every camera frame it makes."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any


def tracked_frames(env: Any, action: Any, tracker: Any) -> Iterator[tuple[Any, Any]]:
    """Run ``action`` with ``env``'s policy to its end; at every camera frame due, ``(obs, tracker.step(obs))``."""
    env.policy.start(action)
    while not env.policy.done:
        env.policy.step()
        if env.world.frame_due():
            obs = env.world.observe()
            yield obs, tracker.step(obs)
