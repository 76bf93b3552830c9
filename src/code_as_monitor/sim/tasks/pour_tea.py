"""``pour-tea`` (surface level, the paper's OmniGibson "Pour Tea"): pour the tea from the teapot into the teacup.

Description: a ``teapot`` (parts ``body``, ``spout``, ``lid`` and ``handle``; an 11 x 11 x 8.6 cm lidded pot,
its local +x towards the spout, the spout an open funnel-shaped trough rising 35 degrees from an opening across
the foot of the front wall, the handle a vertical fin on the back wall; ``assets/teapot.urdf``) holds ``N_TEA``
small spheres of "tea"; a ``teacup`` (parts ``body`` and ``rim``; a square cup with an 8.2 cm opening, 7 cm tall) stands
nearby. Parallel-jaw gripper. Plan: ``grasp`` the pot by its handle, ``transport`` it level until the spout's
end is above the cup, ``pour`` (tilt it forward past the pour angle, pivoting about the spout's end over the
cup), ``drain`` (hold it tilted while the tea runs out), ``level`` it again. The pot stays in the gripper at
the end (success does not ask for it to be put down).
The tea particles are simulated bodies that no object owns: the segmentation labels them as nothing and the
monitor never sees them; only the success check counts them.

Randomisation: pot centre x [0.40, 0.50], y [0.10, 0.18] m, its spout heading -90 +- 35 degrees (towards the
cup's side of the table); cup x [0.42, 0.52], y [-0.20, -0.12] m, yaw uniform in [0, 90) degrees.

Success: at least ``MIN_IN_CUP`` (half) of the tea particles are in the cup and at most ``MAX_SPILLED``
(a fifth) are spilled (neither in the cup nor in the pot or its spout), within the time limit.

Disturbances (config ``disturbance``):
``none``; ``a`` / ``tilt_forward``: in transport (the pot held level, 3 cm closer to the cup than when it was lifted)
an end-effector joint is perturbed: the pot turns in the grasp about the closing axis, spout down, by 55-70 degrees at
``TURN_RATE`` (120 degrees/s, :mod:`code_as_monitor.sim.pour_disturbances`; a pot tipped backwards spills nothing and
the pour, which sets its tilt from the pot's pose when it starts, would still succeed, so only the forward tilt is
used). Past 35 degrees the trough slopes down and the tea runs out over the table (open loop: 8 of 10 seeds fail,
measured; where the turn starts late in the transport, the pour starts from the tipped pose and makes up for it).
``b`` / ``tilt_sideways``: at the same moment the pot turns 40-55 degrees (random side) about the tool's horizontal
axis along the spout, a sideways tilt that the wrist's pitch cannot undo. It is *not a task failure* in this
simulator: the lid keeps the tea in and the funnel spout still pours it into the cup (open loop succeeds; measured up
to 80 degrees); it is a violation of "keep it level" all the same. Both turns go through the grasp constraint, so the
tea moves with the pot, and stop when the policy is halted (the controller holding the measured pose arrests the
joint). ``c`` / ``unpour``: while pouring, as soon as the pot is tilted 40 degrees (the tea has begun to run), the
pour motion is aborted and the wrist returns to level (within 3 degrees) and holds; the next action (open loop: the
drain, at about 40 degrees) starts from wherever it is, and little or no tea runs out.
Events: ``grasp_perturbed`` (obj, ``angle``, ``axis``) for (a) and (b), ``pour_undone`` (``pitch``) for (c).
Expected failure signals: (a), (b) the lid (a surface) is no longer level in transport: its normal is more than
15 degrees from vertical; (c) the pour ends short of the pour angle.

The disturbances' code is in :mod:`code_as_monitor.sim.pour_disturbances`.

Physics: the world runs ``SOLVER_ITERATIONS`` solver iterations (see :meth:`PourTea.load_scene`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.pour_disturbances import Carrying, TurnTrigger, UndoPour
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult

# --- geometry (assets/teapot.urdf, assets/teacup.urdf), metres, in the object's own frame -------------------
POT_HALF = 0.055  # half the pot body's outer width
POT_TOP = 0.086  # top of the lid above the pot's bottom
POT_WALL = 0.006  # wall and floor thickness
SPOUT_BASE = np.array([0.055, 0.0, 0.006])  # spout trough's start (the opening's sill), pot frame
SPOUT_SLOPE = np.radians(35.0)  # the trough rises this much above the pot's floor plane
SPOUT_LEN = 0.09  # trough length along the slope
SPOUT_WALL = 0.025  # trough side wall height
SPOUT_END = SPOUT_BASE + SPOUT_LEN * np.array([np.cos(SPOUT_SLOPE), 0.0, np.sin(SPOUT_SLOPE)])  # (0.129, 0, 0.058)
CUP_HALF_IN = 0.041  # half the cup's inner opening
CUP_TOP = 0.07  # the cup's height (top of its rim)
CUP_FLOOR = 0.005

SOLVER_ITERATIONS = 100  # physics solver iterations in this task's world (see PourTea.load_scene)

# --- tea ----------------------------------------------------------------------------------------------------
N_TEA = 30  # particles; 30 keep the simulator near real time (see the tests' sim-speed note)
TEA_RADIUS = 0.0055  # metres
TEA_MASS = 0.0015  # kg each (45 g of tea in all; a heavier load makes the soft grasp sag more)
MIN_IN_CUP = 0.5  # success: at least this fraction of the tea in the cup ...
MAX_SPILLED = 0.2  # ... and at most this fraction spilled

TILT_FORWARD = (np.radians(55.0), np.radians(70.0))  # (a) the turn in the grasp, radians
TILT_SIDEWAYS = (np.radians(40.0), np.radians(55.0))  # (b)
DISTURBANCES = {"none": "none", "a": "tilt_forward", "b": "tilt_sideways", "c": "unpour",
                "tilt_forward": "tilt_forward", "tilt_sideways": "tilt_sideways", "unpour": "unpour"}


def tea_state(points: np.ndarray, pot_pose: np.ndarray, cup_pose: np.ndarray) -> np.ndarray:
    """Where each tea particle is: (N,) strings ``"cup"``, ``"pot"`` or ``"spilled"``.

    ``points`` (N, 3) particle centres, world metres; ``pot_pose``, ``cup_pose`` (4, 4) world poses of the pot's
    and the cup's base (bottom centre). A particle is in the cup when its centre lies inside the cup's inner box
    (up to 2 cm above the rim: a particle landing on top of others); in the pot when inside the pot's body box
    or over the funnel and spout (a box along the 35-degree slope from the opening's sill)."""
    P = np.asarray(points, float).reshape(-1, 3)

    def local(T: np.ndarray) -> np.ndarray:
        return (P - T[:3, 3]) @ T[:3, :3]

    c, p = local(cup_pose), local(pot_pose)
    ca, sa = np.cos(SPOUT_SLOPE), np.sin(SPOUT_SLOPE)
    d = p - SPOUT_BASE
    s = np.stack([d[:, 0] * ca + d[:, 2] * sa, d[:, 1], -d[:, 0] * sa + d[:, 2] * ca], axis=1)  # slope frame
    in_cup = (np.abs(c[:, 0]) <= CUP_HALF_IN) & (np.abs(c[:, 1]) <= CUP_HALF_IN) & (c[:, 2] >= 0.0) & (
        c[:, 2] <= CUP_TOP + 0.02)
    in_body = (np.abs(p[:, 0]) <= POT_HALF) & (np.abs(p[:, 1]) <= POT_HALF) & (p[:, 2] >= -0.005) & (
        p[:, 2] <= POT_TOP)
    in_spout = (s[:, 0] >= -0.01) & (s[:, 0] <= SPOUT_LEN + 0.005) & (np.abs(s[:, 1]) <= POT_HALF) & (
        s[:, 2] >= -0.01) & (s[:, 2] <= SPOUT_WALL + 0.01)
    return np.where(in_cup, "cup", np.where(in_body | in_spout, "pot", "spilled"))


def poured_ok(state: np.ndarray) -> tuple[bool, str]:
    """Success from :func:`tea_state`'s labels: enough tea in the cup and little spilled."""
    n = max(len(state), 1)
    cup, spilled = int(np.sum(state == "cup")), int(np.sum(state == "spilled"))
    msg = f"{cup} of {n} tea particles in the cup, {spilled} spilled"
    if cup < MIN_IN_CUP * n:
        return False, f"too little tea in the cup: {msg} (needs {MIN_IN_CUP:.0%} in the cup)"
    if spilled > MAX_SPILLED * n:
        return False, f"tea spilled: {msg} (at most {MAX_SPILLED:.0%} may spill)"
    return True, f"the tea is poured: {msg}"


@TaskConfig.register("pour-tea")
@dataclass
class PourTeaConfig(TaskConfig):
    """``disturbance``: none, a (tilt_forward), b (tilt_sideways) or c (unpour)."""

    time_limit: float = 60.0
    disturbance: str = "none"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.disturbance not in DISTURBANCES:
            raise ConfigError(f"pour-tea.disturbance must be one of {', '.join(DISTURBANCES)}; "
                              f"got {self.disturbance!r}")


class PourTea(Task):
    ee_kind = "gripper"
    instruction = "pour the tea from the teapot into the teacup"

    def __init__(self, config: PourTeaConfig) -> None:
        super().__init__(config)
        self.config: PourTeaConfig = config
        self.tea: list[int] = []

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        # The held pot hangs from a chain of bodies (arm -> 0.12 kg tool -> pot with its tea, 10 cm from the grasp
        # point) whose light middle link the solver's default 20 iterations do not converge on: the pot swung and
        # sagged up to 6 degrees relative to the arm's flange while moving (measured: the tool's pose against the
        # flange link's; the constraint's maxForce and ERP change nothing). 100 iterations bring that under 1.3
        # degrees, at twice the simulation cost, for this task's world only.
        pb.setPhysicsEngineParameter(numSolverIterations=SOLVER_ITERATIONS, physicsClientId=c)
        pot = pb.loadURDF(str(ASSETS / "teapot.urdf"), [0.45, 0.14, 0.0], physicsClientId=c)
        cup = pb.loadURDF(str(ASSETS / "teacup.urdf"), [0.47, -0.16, 0.0], physicsClientId=c)
        for b in (pot, cup):
            for link in range(-1, pb.getNumJoints(b, physicsClientId=c)):
                pb.changeDynamics(b, link, lateralFriction=0.5, restitution=0.0, physicsClientId=c)
        world.add_object("teapot", [pot], parts={"body": (pot, -1), "spout": (pot, 0), "lid": (pot, 1),
                                                 "handle": (pot, 2)}, graspable=True)
        world.add_object("teacup", [cup], parts={"body": (cup, -1), "rim": (cup, 0)})
        shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=TEA_RADIUS, physicsClientId=c)
        look = pb.createVisualShape(pb.GEOM_SPHERE, radius=TEA_RADIUS, rgbaColor=[0.55, 0.3, 0.05, 1],
                                    physicsClientId=c)
        self.tea = []
        for _ in range(N_TEA):
            b = pb.createMultiBody(TEA_MASS, shape, look, [0.0, 0.0, -1.0], physicsClientId=c)
            pb.changeDynamics(b, -1, lateralFriction=0.4, rollingFriction=0.002, spinningFriction=0.001,
                              restitution=0.05, linearDamping=0.05, physicsClientId=c)
            self.tea.append(b)

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        pot_xy = np.array([rng.uniform(0.40, 0.50), rng.uniform(0.10, 0.18)])
        heading = -np.pi / 2 + rng.uniform(-0.6, 0.6)
        cup_xy = [rng.uniform(0.42, 0.52), rng.uniform(-0.20, -0.12)]
        q = pb.getQuaternionFromEuler([0, 0, heading])
        pb.resetBasePositionAndOrientation(world.body_of("teapot"), [*pot_xy, 0.0], q, physicsClientId=c)
        pb.resetBasePositionAndOrientation(world.body_of("teacup"), [*cup_xy, 0.0],
                                           pb.getQuaternionFromEuler([0, 0, rng.uniform(0, np.pi / 2)]),
                                           physicsClientId=c)
        # the tea: a loose grid in the back two thirds of the pot, two layers, away from the opening
        R = np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)
        step = 2 * TEA_RADIUS + 0.003
        slots = [(x, y, z) for z in (0, 1, 2) for x in np.arange(-0.040, 0.021, step)
                 for y in np.arange(-0.040, 0.041, step)]
        for b, (x, y, z) in zip(self.tea, slots):
            local = np.array([x, y, POT_WALL + TEA_RADIUS + 0.001 + z * step])
            pos = np.array([*pot_xy, 0.0]) + R @ local
            pb.resetBasePositionAndOrientation(b, pos.tolist(), [0, 0, 0, 1], physicsClientId=c)
            pb.resetBaseVelocity(b, [0, 0, 0], [0, 0, 0], physicsClientId=c)

    # --- interface used by the pour skills ---------------------------------------------------------
    def spout_end(self, world: Any) -> np.ndarray:
        """(3,) world position of the spout trough's outer end (where the tea leaves), metres."""
        T = world.pose("teapot")
        return T[:3, :3] @ SPOUT_END + T[:3, 3]

    def tea_points(self, world: Any) -> np.ndarray:
        """(N, 3) world positions of the tea particles."""
        import pybullet as pb

        return np.array([pb.getBasePositionAndOrientation(b, physicsClientId=world.client)[0] for b in self.tea])

    def tea_labels(self, world: Any) -> np.ndarray:
        """(N,) "cup" / "pot" / "spilled" per particle (see :func:`tea_state`)."""
        return tea_state(self.tea_points(world), world.pose("teapot"), world.pose("teacup"))

    def evaluate(self, world: Any) -> TaskResult:
        labels = self.tea_labels(world)
        ok, reason = poured_ok(labels)
        info = {"t": world.t, "in_cup": int(np.sum(labels == "cup")), "spilled": int(np.sum(labels == "spilled")),
                "in_pot": int(np.sum(labels == "pot")), "n": len(labels),
                "pot_tilt_deg": float(np.degrees(np.arccos(np.clip(world.pose("teapot")[2, 2], -1.0, 1.0))))}
        if ok and world.t > self.config.time_limit + 1e-9:
            ok, reason = False, f"poured after the time limit ({world.t:.1f} s)"
        return TaskResult(ok, reason, info)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": "teapot", "part": "handle"}),
            Action("transport", {"obj": "teapot", "target": "teacup"}),
            Action("pour", {"obj": "teapot", "target": "teacup"}),
            Action("drain", {"obj": "teapot", "target": "teacup"}),
            Action("level", {"obj": "teapot"}),
        ]

    # --- disturbances --------------------------------------------------------------------------------
    def disturbances(self, seed: int = 0) -> list[Any]:
        kind = DISTURBANCES[self.config.disturbance]
        if kind == "tilt_forward":
            return [TurnTrigger(kind, Carrying(), 0, TILT_FORWARD, True, [seed, 31])]
        if kind == "tilt_sideways":
            return [TurnTrigger(kind, Carrying(), 1, TILT_SIDEWAYS, False, [seed, 32])]
        if kind == "unpour":
            return [UndoPour([seed, 33])]
        return []


PourTeaConfig.task_class = PourTea
