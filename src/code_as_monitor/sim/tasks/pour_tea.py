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
``none``; ``a`` / ``tilt_forward``: in transport (the pot held level, 3 cm closer to the cup than when it was
lifted) an end-effector joint is perturbed: the pot turns in the grasp about the closing axis, spout down, by
55-70 degrees at ``TURN_RATE`` (120 degrees/s; a pot tipped backwards spills nothing and the pour, which sets its
tilt from the pot's pose when it starts, would still succeed, so only the forward tilt is used). Past 35 degrees
the trough slopes down and the tea runs out over the table (open loop: 8 of 10 seeds fail, measured; where the turn
starts late in the transport, the pour starts from the tipped pose and makes up for it). ``b`` / ``tilt_sideways``:
at the same moment the pot turns 40-55 degrees (random side) about the tool's horizontal axis along the spout, a
sideways tilt that the wrist's pitch cannot undo. It is *not a task failure* in this simulator: the lid keeps the tea
in and the funnel spout still pours it into the cup (open loop succeeds; measured up to 80 degrees); it is a
violation of "keep it level" all the same. Both turns go through the grasp constraint, so the tea moves with the
pot, and stop when the policy is halted (the controller holding the measured pose arrests the joint).
``c`` / ``unpour``: while pouring, as soon as the pot is tilted 40 degrees (the tea has begun to run), the pour
motion is aborted and the wrist returns to level (within 3 degrees) and holds; the next action (open loop: the
drain, at about 40 degrees) starts from wherever it is, and little or no tea runs out.
Events: ``grasp_perturbed`` (obj, ``angle``, ``axis``) for (a) and (b), ``pour_undone`` (``pitch``) for (c).
Expected failure signals: (a), (b) the lid (a surface) is no longer level in transport: its normal is more than
15 degrees from vertical; (c) the pour ends short of the pour angle.

Physics: the world runs ``SOLVER_ITERATIONS`` solver iterations (see :meth:`PourTea.load_scene`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.disturbances import Disturbance, PolicyWrapper
from code_as_monitor.sim.motion import min_jerk
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult
from code_as_monitor.sim.triggered import Triggered

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
TURN_RATE = np.radians(120.0)  # rad/s: (a) and (b) turn the pot over half a second, not at once
UNPOUR_TILT_DEG = 40.0  # (c) fires once the pot is tilted this far: the 35-degree spout slopes down, tea begins to run
UNPOUR_S = 0.5  # (c) the wrist returns to level over this many seconds
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
            return [TurnTrigger(kind, _Carrying(), 0, TILT_FORWARD, True, [seed, 31])]
        if kind == "tilt_sideways":
            return [TurnTrigger(kind, _Carrying(), 1, TILT_SIDEWAYS, False, [seed, 32])]
        if kind == "unpour":
            return [UndoPour([seed, 33])]
        return []


def _tilt_deg(world: Any) -> float:
    """The pot's tilt: angle between its up axis and world z, degrees."""
    return float(np.degrees(np.arccos(np.clip(world.pose("teapot")[2, 2], -1.0, 1.0))))


class _Carrying:
    """Condition: the pot is held level (within 10 degrees) and has come 3 cm closer (horizontally) to the cup
    than when it was first held level."""

    def __init__(self) -> None:
        self.d0: float | None = None

    def __call__(self, world: Any) -> bool:
        if world.robot.ee.holding != world.body_of("teapot") or _tilt_deg(world) > 10.0:
            return False
        d = float(np.linalg.norm(world.position("teapot")[:2] - world.position("teacup")[:2]))
        if self.d0 is None:
            self.d0 = d
        return d < self.d0 - 0.03


def _tool_rotation(world: Any) -> np.ndarray:
    import pybullet as pb

    orn = pb.getBasePositionAndOrientation(world.robot.ee.body, physicsClientId=world.client)[1]
    return np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))


def _rot(axis: int, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


class TurnInGrasp:
    """Tick hook: the held pot turns in the grasp about the tool's ``axis`` (0 x, 1 y, 2 z) through the grasp
    point, at ``rate`` rad/s until it has turned ``angle`` radians (signed), as a perturbed end-effector joint
    would. The grasp constraint's frame is turned a little each tick, so the solver moves the pot and the tea in
    it moves with it (a pose reset would throw the tea out). The turn stops early when the policy is halted
    (the controller then holds the measured pose, which arrests the perturbed joint); at the end the grasp is
    re-made at the pose reached (the gripper's bookkeeping for save/restore)."""

    def __init__(self, world: Any, axis: int, angle: float, rate: float, halted: Any) -> None:
        import pybullet as pb

        ee = world.robot.ee
        att = ee.attachment()
        if att is None:
            raise ValueError("TurnInGrasp: nothing is held")
        self.body, rel_pos, rel_orn, self.link = att
        self.rel = (tuple(rel_pos), tuple(rel_orn))
        self.cid = ee._constraint
        self.axis, self.angle = int(axis), float(angle)
        self.n = max(1, round(abs(self.angle) / rate / world.dt))
        self.k = 0
        self.halted = halted  # () -> bool: the policy has been halted since the turn began
        self.tip = [0.0, 0.0, float(ee.tip_length)]  # the grasp point in the tool frame
        self._pb = pb

    def _child_frame(self, a: float) -> tuple:
        """The constraint's child frame that holds the pot turned by ``a`` radians from its grasp pose."""
        pb = self._pb
        axis_v = [0.0, 0.0, 0.0]
        axis_v[self.axis] = 1.0
        q = pb.getQuaternionFromAxisAngle(axis_v, a)
        rel_pos = (np.asarray(self.rel[0]) - self.tip).tolist()
        turned_pos, turned_orn = pb.multiplyTransforms([0, 0, 0], q, rel_pos, self.rel[1])
        turned_pos = (np.asarray(turned_pos) + self.tip).tolist()
        ipos, iorn = pb.invertTransform(turned_pos, turned_orn)
        return pb.multiplyTransforms(ipos, iorn, *self.rel)  # rel' ^ -1 * rel

    def __call__(self, world: Any) -> None:
        ee, pb, c = world.robot.ee, self._pb, world.client
        if ee.holding != self.body or ee._constraint != self.cid:  # let go, or re-grasped: nothing to turn
            world.tick_hooks.remove(self)
            return
        if not self.halted() and self.k < self.n:
            self.k += 1
            pos, orn = self._child_frame(self.angle * self.k / self.n)
            pb.changeConstraint(self.cid, jointChildPivot=pos, jointChildFrameOrientation=orn,
                                maxForce=ee.hold_force, physicsClientId=c)
            return
        world.tick_hooks.remove(self)  # re-grasp at the pose reached, so the constraint's frames are plain again
        tpos, torn = pb.getBasePositionAndOrientation(ee.body, physicsClientId=c)
        opos, oorn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        ipos, iorn = pb.invertTransform(tpos, torn)
        rpos, rorn = pb.multiplyTransforms(ipos, iorn, opos, oorn)
        ee.detach()
        ee.attach(self.body, rpos, rorn, self.link)


class TurnTrigger(Triggered):
    """A :class:`~code_as_monitor.sim.triggered.Triggered` turn in the grasp that knows when the policy is
    halted (it wraps the policy), which arrests the turn (:class:`TurnInGrasp`)."""

    def __init__(self, name: str, when: Any, axis: int, angle: tuple[float, float], spout_down: bool,
                 seed: Any = 0) -> None:
        super().__init__(name, when, _tilt_in_grasp(axis, angle, self._halted_since, spout_down), seed)
        self.halts = 0
        self._halts_at_fire = 0

    def _halted_since(self, start: bool = False) -> bool:
        if start:
            self._halts_at_fire = self.halts
        return self.halts > self._halts_at_fire

    def wrap(self, policy: Any) -> Any:
        return _HaltCounter(policy, self)


class _HaltCounter(PolicyWrapper):
    """Forwards to the policy; counts its halts on ``owner.halts``."""

    def __init__(self, inner: Any, owner: TurnTrigger) -> None:
        super().__init__(inner)
        self.owner = owner

    def halt(self) -> None:
        self.owner.halts += 1
        self.inner.halt()


def _tilt_in_grasp(axis: int, angle: tuple[float, float], halted: Any, spout_down: bool = False) -> Any:
    """Effect: start turning the held pot about the tool's ``axis`` by an angle uniform in ``angle`` radians
    (:class:`TurnInGrasp`, at ``TURN_RATE``); the sign is the one that tips the spout down when ``spout_down``,
    else random. Logs ``grasp_perturbed`` (``angle``: the turn planned, ``axis``)."""

    def effect(world: Any, rng: np.random.Generator) -> None:
        a = float(rng.uniform(*angle))
        if spout_down:
            R_tool = _tool_rotation(world)
            spout = R_tool.T @ world.pose("teapot")[:3, 0]  # the pot's +x (to the spout) in the tool frame
            z = [float((R_tool @ _rot(axis, s * a) @ spout)[2]) for s in (1.0, -1.0)]
            a = a if z[0] < z[1] else -a
        else:
            a *= float(rng.choice([-1.0, 1.0]))
        halted(start=True)
        world.tick_hooks.append(TurnInGrasp(world, axis, a, TURN_RATE, halted))
        world.events.log(world.t, "grasp_perturbed", "teapot", angle=a, axis=axis)

    return effect


class UndoPour(Disturbance):
    """(c): once the held pot is tilted past ``UNPOUR_TILT_DEG`` (the tea has begun to run) the pour motion is
    aborted and undone: the policy's current action stops (as a halt would) and the wrist returns to the pose,
    at the same grasp point and yaw, that holds the pot level (give or take 3 degrees). Logs ``pour_undone``.

    It wraps the policy (to stop the running action) and installs a tick hook (the trigger)."""

    name = "unpour"

    def __init__(self, seed: Any = 0) -> None:
        super().__init__(seed)
        self.policy: Any = None
        self.fired_at: float | None = None

    def wrap(self, policy: Any) -> Any:
        self.policy = policy
        return policy

    def install(self, world: Any) -> None:
        world.tick_hooks.append(self._on_tick)

    def _on_tick(self, world: Any) -> None:
        if self.fired_at is not None or world.robot.ee.holding != world.body_of("teapot"):
            return
        if _tilt_deg(world) < UNPOUR_TILT_DEG:
            return
        from code_as_monitor.sim.pour_skills import level_pitch

        self.fired_at = world.t
        robot = world.robot
        up = robot.ee_pose()[:3, :3].T @ world.pose("teapot")[:3, 2]  # the pot's up axis in the flange frame
        pitch = level_pitch(up) + float(self.rng.uniform(-0.05, 0.05))
        if self.policy is not None:
            halted_at = world.halted_at
            self.policy.halt()
            world.halted_at = halted_at  # not a monitor's halt
        q0 = np.array(robot.joints())
        q1 = np.array(robot.ik(robot.tip(), robot.yaw(), pitch))
        n = max(1, round(UNPOUR_S / world.dt))
        starts = len(world.events.of_kind("action_start"))
        k = 0

        def back_to_level(w: Any) -> None:  # a smooth return; ends early when the policy starts a new action
            nonlocal k
            k += 1
            if len(w.events.of_kind("action_start")) > starts or k > n:
                w.tick_hooks.remove(back_to_level)
                return
            w.robot.command(list(q0 + min_jerk(k / n) * (q1 - q0)))

        world.tick_hooks.append(back_to_level)
        world.events.log(world.t, "pour_undone", "teapot", pitch=pitch)


PourTeaConfig.task_class = PourTea
