"""Scripted skills for ``open-drawer`` (oracle, open loop).

Mixed into :class:`~code_as_monitor.sim.policies.ScriptedPolicy`. The handle is grasped with the
gripper skills' ``grasp`` (the task names the bar as the direction to close across; a grasped link of a
fixed-base body is not lifted). Like the other skills, ``pull`` computes its targets from ground truth
when it starts and then plays smooth moves without looking again: a grasp that slips off the handle is
not noticed, the gripper pulls air.

Skills (``Action.skill``, ``Action.args``):

- ``pull {"obj": name, "distance": metres}``: move the grasp point straight along the drawer's opening
  axis (``task.pull_axis``, world frame) by ``distance`` at ``PULL_SPEED``, wait, open the gripper,
  retreat ``PULL_RETREAT`` straight up and park.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from code_as_monitor.core.errors import SimError
from code_as_monitor.sim.motion import SLOW_SPEED

DRAWER_SKILLS: dict[str, tuple[tuple[str, ...], str]] = {
    "pull": (("obj",), "gripper"),
}
"""Skill -> (required args naming objects, end-effector kind)."""

PULL_SPEED = 0.08  # m/s mean speed of the pull (a 17 cm pull takes about 2 s)
PULL_RETREAT = 0.10  # metres straight up after letting go: the fingers (4.5 cm) clear the bar
PULL_PARK = (0.32, -0.33, 0.30)  # tip position out of the cameras' way, metres
MAX_PULL = 0.30  # metres: longer than any drawer's travel here (assets/drawer_cabinet.urdf: 25 cm)


class DrawerSkills:
    """Skill generators for ``open-drawer``; expects ``world``, ``task``, ``mover``, ``_aabb`` and ``_lift``."""

    world: Any
    task: Any
    mover: Any
    noise: Any

    def _pull(self, obj: str, distance: float = 0.17) -> Iterator[None]:
        """Pull the grasped handle ``distance`` metres along the drawer's opening axis, let go and retreat."""
        d = float(distance)
        if not 0.0 <= d <= MAX_PULL:
            raise SimError(f"pull: distance must be in [0, {MAX_PULL}] metres, got {distance!r}")
        pull_axis = getattr(self.task, "pull_axis", None)
        if pull_axis is None:
            raise SimError(f"pull: task {getattr(self.task, 'name', '?')!r} has no drawer to pull")
        u = np.asarray(pull_axis(self.world, obj), float)
        u = u / max(float(np.linalg.norm(u)), 1e-9)
        d *= 1.0 + self.noise.normal("pull_rel")  # a learned policy's imprecision (exact by default)
        start = self.mover.tip.copy()
        end = start + d * u
        yield from self.mover.move(end, speed=PULL_SPEED)
        yield from self.mover.wait(0.1)
        self._grip_open()  # type: ignore[attr-defined]
        yield from self.mover.wait(0.2)
        self._judge("pull", obj=obj)  # type: ignore[attr-defined]
        yield from self.mover.move([*end[:2], end[2] + PULL_RETREAT], speed=SLOW_SPEED * 2)
        yield from self.mover.move(PULL_PARK, pitch=0.0)
