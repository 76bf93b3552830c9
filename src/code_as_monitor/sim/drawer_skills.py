"""Scripted skills for ``open-drawer`` (oracle, open loop).

Mixed into :class:`~code_as_monitor.sim.policies.ScriptedPolicy`.
"""

from __future__ import annotations

DRAWER_SKILLS: dict[str, tuple[tuple[str, ...], str]] = {}
"""Skill -> (required args naming objects, end-effector kind)."""


class DrawerSkills:
    """Skill generators for ``open-drawer``; expects ``world``, ``task``, ``mover``, ``_aabb`` and ``_lift``."""
