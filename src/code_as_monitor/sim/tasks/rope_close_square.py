"""``rope-close-square``: use the rope to close the opening of the square.

Description: a ``rope`` of ``n_beads`` spheres (parts ``bead_00`` ...; neighbours joined by
point-to-point constraints) and a static open ``square`` outline (parts ``corner_0`` .. ``corner_3``;
three sides are bars, the side between ``corner_3`` and ``corner_0`` is the opening). Suction tool.

Randomisation: square centre x 0.45 +- 0.03, y -0.08 +- 0.03 m, yaw pi/2 +- 0.25 rad (opening
towards +y); the rope is a random smooth curve about 15 cm outside the opening.

Success: the policy was halted (``World.halted_at`` set) within ``time_limit`` (70 s) and the opening
is enclosed: at least ``min_coverage`` of ``n_samples`` points along corner_3 -> corner_0 have a resting
bead (not lifted) within ``cover_tol`` metres (horizontal). The open-loop ``close_shape`` skill keeps adjusting the rope
forever (it aims at a perfect line), so it never halts: open-loop success is 0 % as in the paper.

Disturbances: none. Expected failure signal: the opening is enclosed but the policy keeps moving.
Events: ``opening_enclosed`` / ``opening_open`` (``coverage``) when the coverage crosses the threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError, SimError
from code_as_monitor.core.registry import check_positive, check_probability
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult

HALF = 0.1  # square inner half-size, metres (assets/square.urdf)
INSTRUCTION = "use the rope to close the opening of the square"
DEFAULT_COVERAGE = 0.9  # the simulator's "enclosed": 90 % of the samples along the opening
CORNERS = {"corner_0": (HALF, HALF), "corner_1": (-HALF, HALF), "corner_2": (-HALF, -HALF), "corner_3": (HALF, -HALF)}


def opening_coverage(beads_xy: np.ndarray, a: np.ndarray, b: np.ndarray, tol: float, n_samples: int = 11) -> float:
    """Fraction of ``n_samples`` points on segment a-b (2,) with a bead (N, 2) within ``tol`` metres."""
    s = np.linspace(0.0, 1.0, n_samples)[:, None]
    pts = np.asarray(a)[None] * (1 - s) + np.asarray(b)[None] * s
    d = np.linalg.norm(pts[:, None, :] - np.asarray(beads_xy)[None, :, :2], axis=2).min(axis=1)
    return float(np.mean(d <= tol))


@TaskConfig.register("rope-close-square")
@dataclass
class RopeCloseSquareConfig(TaskConfig):
    """Rope of ``n_beads`` (radius ``bead_radius`` m, ``spacing`` m apart); success thresholds."""

    time_limit: float = 70.0
    n_beads: int = 20
    bead_radius: float = 0.008
    spacing: float = 0.017
    cover_tol: float = 0.025
    min_coverage: float = DEFAULT_COVERAGE
    n_samples: int = 11

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 4 <= self.n_beads <= 60:
            raise ConfigError(f"rope-close-square.n_beads must be in [4, 60], got {self.n_beads!r}")
        check_positive("rope-close-square", "bead_radius", self.bead_radius)
        check_positive("rope-close-square", "cover_tol", self.cover_tol)
        check_probability("rope-close-square", "min_coverage", self.min_coverage)
        if self.spacing < 2 * self.bead_radius:
            raise ConfigError(f"rope-close-square.spacing ({self.spacing}) must be >= 2 * bead_radius")
        if self.n_samples < 2:
            raise ConfigError(f"rope-close-square.n_samples must be >= 2, got {self.n_samples}")


def describe_coverage(min_coverage: float) -> str:
    """The instruction for a coverage goal (the instruction grammar reads it back to the same fraction)."""
    if abs(min_coverage - DEFAULT_COVERAGE) < 1e-9:
        return INSTRUCTION
    return f"use the rope to close {round(min_coverage * 100, 2):g} % of the opening of the square"


class RopeCloseSquare(Task):
    ee_kind = "suction"

    @property
    def instruction(self) -> str:  # type: ignore[override]
        return self.config.instruction or describe_coverage(self.config.min_coverage)

    def __init__(self, config: RopeCloseSquareConfig) -> None:
        super().__init__(config)
        self.config: RopeCloseSquareConfig = config
        self.beads = [f"bead_{i:02d}" for i in range(config.n_beads)]
        self._enclosed: bool | None = None

    def load_scene(self, world) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c, cfg = world.client, self.config
        sq = pb.loadURDF(str(ASSETS / "square.urdf"), [0.45, -0.08, 0.0], useFixedBase=True, physicsClientId=c)
        links = {pb.getJointInfo(sq, j, physicsClientId=c)[12].decode(): j
                 for j in range(pb.getNumJoints(sq, physicsClientId=c))}
        world.add_object("square", [sq], parts={k: (sq, links[k]) for k in CORNERS}, whole=[(sq, -1)])
        col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=cfg.bead_radius, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_SPHERE, radius=cfg.bead_radius, rgbaColor=[0.95, 0.5, 0.1, 1],
                                   physicsClientId=c)
        bodies = []
        for i in range(cfg.n_beads):
            b = pb.createMultiBody(0.02, col, vis, [0.2 + i * cfg.spacing, 0.6, cfg.bead_radius], physicsClientId=c)
            pb.changeDynamics(b, -1, lateralFriction=0.6, restitution=0.0, linearDamping=0.2, angularDamping=0.5,
                              physicsClientId=c)
            bodies.append(b)
        for i in range(cfg.n_beads - 1):
            h = cfg.spacing / 2
            cid = pb.createConstraint(bodies[i], -1, bodies[i + 1], -1, pb.JOINT_POINT2POINT, [0, 0, 0], [h, 0, 0],
                                      [-h, 0, 0], physicsClientId=c)
            pb.changeConstraint(cid, maxForce=30, physicsClientId=c)
            pb.setCollisionFilterPair(bodies[i], bodies[i + 1], -1, -1, 0, physicsClientId=c)
        world.add_object("rope", bodies, parts={n: (b, -1) for n, b in zip(self.beads, bodies)}, pose_body=None,
                         graspable=True)

    def reset(self, world) -> None:
        import pybullet as pb

        rng, c, cfg = world.rng, world.client, self.config
        center = np.array([0.45 + rng.uniform(-0.03, 0.03), -0.08 + rng.uniform(-0.03, 0.03)])
        yaw = np.pi / 2 + rng.uniform(-0.25, 0.25)
        pb.resetBasePositionAndOrientation(world.body_of("square"), [*center, 0.0],
                                           pb.getQuaternionFromEuler([0, 0, yaw]), physicsClientId=c)
        out = np.array([np.cos(yaw), np.sin(yaw)])  # outward normal of the opening
        heading = yaw + np.pi / 2 + rng.uniform(-0.5, 0.5)
        pts = [np.zeros(2)]
        for _ in range(cfg.n_beads - 1):
            heading += rng.uniform(-0.35, 0.35)
            pts.append(pts[-1] + cfg.spacing * np.array([np.cos(heading), np.sin(heading)]))
        P = np.array(pts)
        P += center + out * (HALF + 0.15 + rng.uniform(-0.02, 0.02)) - P.mean(0)
        for name, p in zip(self.beads, P):
            b = world.objects["rope"].parts[name][0]
            pb.resetBasePositionAndOrientation(b, [*p, cfg.bead_radius], [0, 0, 0, 1], physicsClientId=c)
        self._enclosed = None

    # --- interface used by the close_shape skill ---------------------------------------------------------
    def rope_parts(self, rope: str) -> list[str]:
        if rope != "rope":
            raise SimError(f"unknown rope {rope!r}; this task has: rope")
        return list(self.beads)

    def opening(self, world) -> tuple[np.ndarray, np.ndarray]:
        """(corner_3 xy, corner_0 xy): the ends of the opening, world metres."""
        return world.position("square/corner_3")[:2], world.position("square/corner_0")[:2]

    def rope_targets(self, world, rope: str, shape: str) -> np.ndarray:
        """(n_beads, 2) bead targets: evenly along the opening line, just outside it, centred on it."""
        if shape != "square":
            raise SimError(f"unknown shape {shape!r}; this task has: square")
        a, b = self.opening(world)
        u = (b - a) / np.linalg.norm(b - a)
        center = world.position("square")[:2]
        mid = (a + b) / 2
        out = (mid - center) / np.linalg.norm(mid - center)
        n, sp = self.config.n_beads, self.config.spacing
        s = (np.arange(n) - (n - 1) / 2) * sp * 0.85  # with some slack: a taut rope snaps back
        T = mid[None] + s[:, None] * u[None] + out[None] * 0.015
        cur = np.array([world.position(f"{rope}/{x}")[:2] for x in self.beads])
        if np.linalg.norm(cur - T[::-1], axis=1).sum() < np.linalg.norm(cur - T, axis=1).sum():
            T = T[::-1]
        return T

    def coverage(self, world) -> float:
        P = np.array([world.position(f"rope/{x}") for x in self.beads])
        beads = P[P[:, 2] <= 2 * self.config.bead_radius + 0.01, :2]  # resting beads only, not a carried one
        if len(beads) == 0:
            return 0.0
        a, b = self.opening(world)
        return opening_coverage(beads, a, b, self.config.cover_tol, self.config.n_samples)

    def on_tick(self, world) -> None:
        if world.ticks % 4:
            return
        cov = self.coverage(world)
        enclosed = cov >= self.config.min_coverage
        if enclosed != self._enclosed:
            if self._enclosed is not None or enclosed:
                world.events.log(world.t, "opening_enclosed" if enclosed else "opening_open", "rope", coverage=cov)
            self._enclosed = enclosed

    def evaluate(self, world) -> TaskResult:
        cov = self.coverage(world)
        info = {"t": world.t, "coverage": cov, "halted_at": world.halted_at}
        if cov < self.config.min_coverage:
            return TaskResult(False, f"opening not enclosed (coverage {cov:.2f} < {self.config.min_coverage})", info)
        if world.halted_at is None:
            return TaskResult(False, "opening enclosed but execution was never halted", info)
        if world.halted_at > self.config.time_limit + 1e-9:
            return TaskResult(False, f"halted after the time limit ({world.halted_at:.1f} s)", info)
        return TaskResult(True, f"opening enclosed (coverage {cov:.2f}), halted at {world.halted_at:.1f} s", info)

    def default_plan(self) -> list[Action]:
        return [Action("close_shape", {"rope": "rope", "shape": "square"})]

    def settle_after_plan(self) -> bool:
        return False


RopeCloseSquareConfig.task_class = RopeCloseSquare
