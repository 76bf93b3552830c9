"""A learned policy's imprecision, as seeded noise on the scripted skills' decisions (the RLBench-style tasks).

The paper's RLBench column is a learned policy (ARP) whose own mistakes are the failures: no disturbance is
injected. Our analogue keeps the scripted (oracle) skills and perturbs the decisions a learned policy gets
slightly wrong: where it grasps (an offset of the grasp point and of the tool's yaw), how far it moves (a pull,
a turn, a drag, a sweep stroke: a relative error of the commanded amount), where it puts things (an offset of
a place or contact point) and, rarely, which of two alike parts it acts on (a wrong target). Each task names
the standard deviations (metres, radians or a fraction) and the probabilities of its decisions in a
``{name: value}`` table (``Task.action_noise``); ``scale`` multiplies them all (0: the clean oracle).

Draws come from the noise's own generator, seeded from the episode seed, never from ``world.rng``: the scene
and any disturbance are the same with or without noise, and every method sees the same draws for the same
episode seed as long as it asks the policy for the same actions in the same order.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from code_as_monitor.core.errors import ConfigError

NOISE_SEED_TAG = 77
"""Second word of the noise generator's seed (``[episode seed, NOISE_SEED_TAG]``)."""


class ActionNoise:
    """Seeded noise for named decisions.

    Args:
        params: decision name -> standard deviation (``normal``/``offset``) or probability (``chance``).
        scale: multiplies every standard deviation and probability (probabilities are clipped to [0, 1]).
        seed: the episode seed.
    """

    def __init__(self, params: Mapping[str, float] | None = None, scale: float = 1.0, seed: int = 0) -> None:
        if not np.isfinite(scale) or scale < 0:
            raise ConfigError(f"action noise scale must be a finite number >= 0, got {scale!r}")
        for k, v in (params or {}).items():
            if not np.isfinite(v) or v < 0:
                raise ConfigError(f"action noise {k!r} must be a finite number >= 0, got {v!r}")
        self.params = dict(params or {})
        self.scale = float(scale)
        self.rng = np.random.default_rng([int(seed) & 0x7FFFFFFF, NOISE_SEED_TAG])
        self.draws: list[tuple[str, object]] = []
        """Every draw made, in order (name, value): what the policy got wrong, for tests and reports."""

    @property
    def active(self) -> bool:
        """True when any decision is perturbed."""
        return self.scale > 0 and any(v > 0 for v in self.params.values())

    def _sigma(self, name: str) -> float:
        return self.scale * float(self.params.get(name, 0.0))

    def normal(self, name: str) -> float:
        """A zero-mean normal draw with the standard deviation named ``name`` (0.0 without a draw if it is 0)."""
        s = self._sigma(name)
        if s <= 0:
            return 0.0
        x = float(self.rng.normal(0.0, s))
        self.draws.append((name, x))
        return x

    def offset(self, name: str, dims: int = 2) -> np.ndarray:
        """A zero-mean isotropic normal offset (``dims``,) with the standard deviation ``name`` per axis."""
        s = self._sigma(name)
        if s <= 0:
            return np.zeros(dims)
        x = self.rng.normal(0.0, s, size=dims)
        self.draws.append((name, x.tolist()))
        return x

    def chance(self, name: str) -> bool:
        """True with the probability named ``name`` (never when it is 0, without a draw)."""
        p = min(1.0, self._sigma(name))
        if p <= 0:
            return False
        hit = bool(self.rng.random() < p)
        self.draws.append((name, hit))
        return hit


NO_NOISE = ActionNoise()
"""The clean oracle: every decision exact."""

__all__ = ["NOISE_SEED_TAG", "NO_NOISE", "ActionNoise"]
