"""Scripted skills for ``pour-tea`` (oracle, open loop).

Mixed into :class:`~code_as_monitor.sim.policies.ScriptedPolicy`.
"""

from __future__ import annotations

POUR_SKILLS: dict[str, tuple[tuple[str, ...], str]] = {}
"""Skill -> (required args naming objects, end-effector kind)."""


class PourSkills:
    """Skill generators for ``pour-tea``; expects ``world``, ``task``, ``mover``, ``_aabb`` and ``_lift``."""
