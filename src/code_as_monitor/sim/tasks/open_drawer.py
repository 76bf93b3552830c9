"""``open-drawer`` (articulated object): grasp the drawer's handle and pull the drawer open.

Description: a ``drawer_cabinet`` (``assets/drawer_cabinet.urdf``; a fixed-base articulated body, 26 cm
deep, 28 cm wide, 10 cm tall) stands on the table with its front towards the robot. Parts, each its own
link and so its own segmentation id: ``frame`` (the box, base link), ``drawer`` (front plate and tray, on
a prismatic joint along the cabinet's local +x, 0 .. 25 cm; its front plate laid over the frame's front)
and ``handle`` (a 10 cm bar 3.5 cm in front of the drawer front, 8 cm above the table, so that the front
camera sees it over the cabinet while the gripper's hand hides it from the top camera). Parallel-jaw
gripper; its closed grasp of a fixed-base body fixes the grasped LINK (the handle) to the tool, so moving
the tool drags the drawer along its joint. The joint has damping and a weak friction motor, so the drawer
stays where it is left.
Plan: ``grasp`` the handle (jaws across the bar; no lift), ``pull`` the drawer ``min_open`` plus
``PULL_MARGIN`` along its axis, open the gripper and retreat.

Randomisation: the handle's centre at a distance [0.46, 0.54] m from the robot base at a bearing
uniform in [-20, 20] degrees; the cabinet turned so that its front faces the robot base within
+-15 degrees (the pull goes towards the base, so the fully pulled handle stays within reach).

Success: the drawer is open by at least ``min_open`` (config; default ``OPEN_MIN``, 15 cm; its joint
position) and the gripper has let go of it (nothing holds the cabinet), within the time limit. An
instruction sets ``min_open`` ("open the drawer 10 cm", "halfway": see the kb's drawer family).

Disturbances (config ``disturbance``):
``none``; ``slip``: mid-pull (the first tick the gripper holds the handle and the drawer is open by a
distance uniform in [3, 7] cm) the grasp slips off the handle: the attachment is removed, the fingers
stay closed (event ``grasp_slipped``). The open-loop policy keeps pulling air, opens and retreats; the
drawer stays 3-7 cm open, so the open loop fails.
Learned-policy analogue (the RLBench suite): ``noise`` > 0 perturbs the grasp and the pull's length (``NOISE``) and
logs the first failed skill as a ``policy_failure`` (``grasp_missed``, ``pull_short``; see
:mod:`code_as_monitor.sim.tasks.rlbench_base`); ``views="rlbench"`` gives it RLBench's four cameras.
Expected failure signals: the handle is no longer at the grasp point while the gripper pulls (the
grasp point moves on along the pull, the handle and the drawer front stay); after the pull the drawer
front has moved less than the required distance.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult
from code_as_monitor.sim.triggered import Triggered

OBJ = "drawer_cabinet"
OPEN_MIN = 0.15  # metres: open by over half the 22 cm tray depth (assets/drawer_cabinet.urdf), enough to reach in
PULL_MARGIN = 0.02  # metres the scripted pull goes past the opening asked for: the soft grasp's lag
PULL_DISTANCE = OPEN_MIN + PULL_MARGIN  # metres the scripted pull moves the grasp point by default
JOINT_LIMIT = 0.25  # metres, the prismatic joint's upper limit (assets/drawer_cabinet.urdf)
HANDLE_OFFSET = 0.18  # handle centre ahead of the cabinet origin along local +x, closed: 0.13 + 0.015 + 0.035 m
DRAWER_FRICTION = 0.5  # newtons: a 0.6 kg drawer on ball-bearing slides (friction coefficient below 0.1)
SLIP_OPENING = (0.03, 0.07)  # metres open when the grasp slips (the ``slip`` disturbance)
DISTURBANCES = ("none", "slip")


def drawer_open(opening: float, held: bool, min_open: float = OPEN_MIN) -> tuple[bool, str]:
    """Is the drawer open and let go? ``opening``: its joint position (metres out of the frame);
    ``held``: the gripper still holds the cabinet (its handle)."""
    if opening < min_open:
        return False, f"the drawer is open {opening * 100:.1f} cm, less than {min_open * 100:.1f} cm"
    if held:
        return False, f"the drawer is open {opening * 100:.1f} cm but the gripper still holds the handle"
    return True, f"the drawer is open {opening * 100:.1f} cm and released"


@TaskConfig.register("open-drawer")
@dataclass
class OpenDrawerConfig(TaskConfig):
    """``disturbance``: none or slip (the grasp slips off the handle mid-pull); ``min_open``: metres the
    drawer must be open for success (0 < min_open <= JOINT_LIMIT - PULL_MARGIN). ``noise``: the policy's action
    noise (0, the default: the exact oracle of Table 2; 1: the RLBench suite's learned-policy analogue, see
    :mod:`code_as_monitor.sim.tasks.rlbench_base`); ``views``: ``default`` (front and top) or ``rlbench`` (the
    four RLBench cameras)."""

    time_limit: float = 60.0
    disturbance: str = "none"
    min_open: float = OPEN_MIN
    noise: float = 0.0
    views: str = "default"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0.0 < float(self.min_open) <= JOINT_LIMIT - PULL_MARGIN + 1e-9:
            raise ConfigError(f"open-drawer.min_open must be in (0, {JOINT_LIMIT - PULL_MARGIN:.2f}] metres; "
                              f"got {self.min_open!r}")
        if not isinstance(self.noise, (int, float)) or not 0.0 <= float(self.noise) <= 10.0:
            raise ConfigError(f"open-drawer.noise must be a number in [0, 10], got {self.noise!r}")
        if self.views not in ("default", "rlbench"):
            raise ConfigError(f"open-drawer.views must be default or rlbench, got {self.views!r}")
        if self.disturbance not in DISTURBANCES:
            raise ConfigError(f"open-drawer.disturbance must be one of {', '.join(DISTURBANCES)}; "
                              f"got {self.disturbance!r}")


INSTRUCTION = "open the drawer by pulling its handle"


def describe_opening(min_open: float) -> str:
    """The instruction for an opening goal (the instruction grammar reads it back to the same opening)."""
    if abs(min_open - OPEN_MIN) < 1e-9:
        return INSTRUCTION
    return f"open the drawer {round(min_open * 100, 2):g} cm by pulling its handle"


class OpenDrawer(Task):
    ee_kind = "gripper"

    @property
    def instruction(self) -> str:  # type: ignore[override]
        return self.config.instruction or describe_opening(self.config.min_open)

    def __init__(self, config: OpenDrawerConfig) -> None:
        super().__init__(config)
        self.config: OpenDrawerConfig = config
        self.joint = -1  # index of the drawer's prismatic joint (its child link is the ``drawer`` part)

    NOISE: ClassVar[dict[str, float]] = {"grasp_xy": 0.008, "grasp_z": 0.003, "grasp_yaw": 0.05, "pull_rel": 0.065}
    """The learned-policy analogue's noise (``noise`` > 0 only); see ``rlbench_base``."""

    def action_noise(self, seed: int) -> Any:
        from code_as_monitor.sim.action_noise import ActionNoise

        return ActionNoise(self.NOISE, float(self.config.noise), seed)

    def camera_specs(self, width: int, height: int) -> list[Any] | None:
        if self.config.views != "rlbench":
            return None
        from code_as_monitor.sim.cameras import rlbench_cameras

        return rlbench_cameras(width, height)

    def judge(self, world: Any, skill: str, args: dict[str, Any]) -> str | None:
        """With a noisy policy, the first failed skill (a ``policy_failure``): ``grasp_missed`` or ``pull_short``
        (released with the drawer open less than ``min_open``); the exact oracle logs none (its failures are the
        disturbance's)."""
        if self.config.noise <= 0:
            return None
        if skill == "pull" and self.opening(world) < self.config.min_open:
            return "pull_short"
        if skill == "grasp":
            from code_as_monitor.sim.tasks.rlbench_base import grasp_failure

            part = str(args.get("part", ""))
            return grasp_failure(world, args["obj"], part, str(args.get("intended", part)))
        return None

    def load_scene(self, world: Any) -> None:
        self.joint = load_cabinet(world)

    def reset(self, world: Any) -> None:
        place_cabinet(world, self.joint)

    # --- interface used by the gripper and drawer skills ---------------------------------------------
    def opening(self, world: Any) -> float:
        """The drawer's joint position: metres it is pulled out of the frame (0 closed)."""
        import pybullet as pb

        return float(pb.getJointState(world.body_of(OBJ), self.joint, physicsClientId=world.client)[0])

    def pull_axis(self, world: Any, obj: str) -> np.ndarray:
        """(3,) world unit direction in which the drawer opens (the cabinet's local +x)."""
        return world.pose(obj)[:3, 0].copy()

    def grasp_axis(self, world: Any, obj: str, part: str = "") -> np.ndarray:
        """(3,) world direction the jaws close ACROSS: for the handle, its bar (the handle link's local y)."""
        if part == "handle":
            return world.pose(f"{obj}/handle")[:3, 1].copy()
        return world.pose(obj)[:3, 1].copy()

    def evaluate(self, world: Any) -> TaskResult:
        q = self.opening(world)
        held = world.robot.ee.holding == world.body_of(OBJ)
        ok, reason = drawer_open(q, held, self.config.min_open)
        info = {"t": world.t, "opening": q, "min_open": self.config.min_open,
                "handle": world.position(f"{OBJ}/handle").tolist()}
        if ok and world.t > self.config.time_limit + 1e-9:
            ok, reason = False, f"opened after the time limit ({world.t:.1f} s)"
        return TaskResult(ok, reason, info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": OBJ, "part": "handle"}),
            Action("pull", {"obj": OBJ, "distance": round(self.config.min_open + PULL_MARGIN, 4)}),
        ]

    # --- disturbances --------------------------------------------------------------------------------
    def disturbances(self, seed: int = 0) -> list[Any]:
        if self.config.disturbance == "slip":
            return [Triggered("slip", _PullSlip(self, seed), _slip_off_handle, [seed, 31])]
        return []


def load_cabinet(world: Any) -> int:
    """Load ``assets/drawer_cabinet.urdf`` as object ``drawer_cabinet`` (parts ``frame``, ``drawer``, ``handle``;
    graspable) with the drawer's sliding friction; returns the drawer's prismatic joint index."""
    import pybullet as pb

    from code_as_monitor.sim.world import ASSETS

    c = world.client
    body = pb.loadURDF(str(ASSETS / "drawer_cabinet.urdf"), [0.65, 0.0, 0.0],
                       pb.getQuaternionFromEuler([0, 0, np.pi]), useFixedBase=True, physicsClientId=c)
    links = {pb.getJointInfo(body, j, physicsClientId=c)[12].decode(): j
             for j in range(pb.getNumJoints(body, physicsClientId=c))}
    # sliding friction as a velocity motor (target 0) with a small force: the drawer stays where it is left
    pb.setJointMotorControl2(body, links["drawer"], pb.VELOCITY_CONTROL, targetVelocity=0.0, force=DRAWER_FRICTION,
                             physicsClientId=c)
    for link in (-1, *links.values()):
        pb.changeDynamics(body, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
    world.add_object(OBJ, [body], parts={"frame": (body, -1), "drawer": (body, links["drawer"]),
                                         "handle": (body, links["handle"])}, graspable=True)
    return links["drawer"]


def place_cabinet(world: Any, joint: int) -> float:
    """Randomise the cabinet with ``world.rng`` (see the module docstring) and close its drawer; returns the
    handle's bearing from the robot base (radians)."""
    import pybullet as pb

    rng, c = world.rng, world.client
    r, bearing = rng.uniform(0.46, 0.54), rng.uniform(-np.radians(20), np.radians(20))
    handle = r * np.array([np.cos(bearing), np.sin(bearing)])
    yaw = bearing + np.pi + rng.uniform(-np.radians(15), np.radians(15))  # local +x towards the base
    origin = handle - HANDLE_OFFSET * np.array([np.cos(yaw), np.sin(yaw)])
    body = world.body_of(OBJ)
    pb.resetBasePositionAndOrientation(body, [*origin, 0.0], pb.getQuaternionFromEuler([0, 0, yaw]),
                                       physicsClientId=c)
    pb.resetJointState(body, joint, 0.0, 0.0, physicsClientId=c)
    return float(bearing)


class _PullSlip:
    """Condition: the gripper holds the cabinet and the drawer is open by a distance drawn once, uniform in
    ``SLIP_OPENING`` (from its own generator, so the moment does not depend on other draws)."""

    def __init__(self, task: OpenDrawer, seed: int) -> None:
        self.task = task
        self.at = float(np.random.default_rng([seed, 32]).uniform(*SLIP_OPENING))

    def __call__(self, world: Any) -> bool:
        if world.robot.ee.holding != world.body_of(OBJ):
            return False
        return self.task.opening(world) >= self.at


def _slip_off_handle(world: Any, rng: np.random.Generator) -> None:
    """Effect: the grasp slips off the handle: the attachment goes, the fingers stay closed (the open-loop
    policy does not know)."""
    body = world.robot.ee.detach()
    world.events.log(world.t, "grasp_slipped", world.name_of(body), tip=world.robot.tip().tolist())


OpenDrawerConfig.task_class = OpenDrawer
