"""What the RLBench-style tasks share: four cameras, a parallel-jaw gripper, a noisy policy, judged outcomes.

The paper's RLBench experiment (supplementary, "RLBench") runs a learned policy (ARP) with a Franka gripper and
four cameras (front, left and right shoulder, wrist), injects no disturbance (the policy's own mistakes are the
failures) and abandons an episode that the monitor flags. Our tasks keep that shape:

- cameras: :func:`code_as_monitor.sim.cameras.rlbench_cameras` (the wrist camera follows the hand);
- policy: the scripted skills with seeded action noise (:mod:`code_as_monitor.sim.action_noise`), each task's
  table ``NOISE`` scaled by the config's ``noise`` (0: the exact oracle), tuned so that the open loop succeeds
  about as often as ARP does in the paper's table (86-97 %), not always;
- ground truth: the task judges each skill's outcome where it is decided (``judge``) and the policy logs the
  episode's first failed one as a ``policy_failure`` event (``what``: ``grasp_missed``, ``wrong_target``,
  ``pull_short``, ``item_misplaced``, ``screw_short``, ``turn_short``, ``cube_off_target``, ``dirt_left``);
  that is the failure the detection metrics score alarms against.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.action_noise import ActionNoise
from code_as_monitor.sim.tasks.base import Task, TaskConfig

POLICY_FAILURES = ("grasp_missed", "wrong_target", "pull_short", "item_misplaced", "screw_short", "turn_short",
                   "cube_off_target", "dirt_left")
"""The ``what`` of a ``policy_failure`` event."""


@dataclass
class RLBenchConfig(TaskConfig):
    """``noise``: scale of the policy's action noise (1: the task's tuned learned-policy analogue, 0: exact)."""

    time_limit: float = 60.0
    noise: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.noise, (int, float)) or not 0.0 <= float(self.noise) <= 10.0:
            raise ConfigError(f"{type(self).__name__}.noise must be a number in [0, 10], got {self.noise!r}")


class RLBenchTask(Task):
    """Base of the RLBench-style tasks; subclasses set ``NOISE`` and implement ``judge``."""

    ee_kind = "gripper"
    proactive_confirmation = "task_failure"
    NOISE: ClassVar[dict[str, float]] = {}
    """Decision -> standard deviation (metres, radians, or a fraction for ``*_rel``) or probability."""

    def __init__(self, config: RLBenchConfig) -> None:
        super().__init__(config)
        self.config: RLBenchConfig = config

    def camera_specs(self, width: int, height: int) -> list[Any]:
        from code_as_monitor.sim.cameras import rlbench_cameras

        return rlbench_cameras(width, height)

    def action_noise(self, seed: int) -> ActionNoise:
        return ActionNoise(self.NOISE, float(self.config.noise), seed)

    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        """The ``what`` of a failed outcome of ``skill`` (see ``POLICY_FAILURES``), None when it did its job."""
        if skill == "grasp":
            part = str(args.get("part", ""))
            return grasp_failure(world, args["obj"], part, str(args.get("intended", part)))
        return None


def grasp_failure(world: Any, obj: str, grasped: str, intended: str) -> str | None:
    """``grasp_missed`` when the gripper holds nothing of ``obj`` after closing, ``wrong_target`` when it holds a
    part other than the ``intended`` one (a link of a fixed-base body; ``grasped`` is the part it aimed at),
    None when the grasp holds what it should."""
    ee = world.robot.ee
    att = ee.attachment() if hasattr(ee, "attachment") else None
    if att is None or world.name_of(att[0]) != obj:
        return "grasp_missed"
    link = att[3] if len(att) > 3 else -1
    if link >= 0 and intended:  # a fixed-base body: the grasped link is the part
        parts = world.objects[obj].parts
        held = next((p for p, (_, li) in parts.items() if li == link), "")
        if held != intended:
            return "wrong_target" if held == grasped and grasped != intended else "grasp_missed"
    return None


__all__ = ["POLICY_FAILURES", "RLBenchConfig", "RLBenchTask", "grasp_failure"]
