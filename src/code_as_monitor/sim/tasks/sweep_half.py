"""``sweep-half``: sweep half of the 40 blocks into the marked zone.

Description: 40 small 2 cm blocks (``block_00`` ... ``block_39``) lie on the table beside a marked
square ``zone`` (part ``surface``, 16 x 16 cm, visual only); the robot holds a spatula.

Randomisation: zone centre x 0.5 +- 0.03, y 0.2 +- 0.03 m; blocks uniform in a 0.2 x 0.26 m patch on
the robot's right of the zone (>= 2.8 cm apart), random yaw and colour shade.

Success: ``min_in_zone`` (16) to ``max_in_zone`` (24; an instruction sets both) block centres inside the zone
when evaluated
(at ``time_limit`` = 30 s in the open-loop benchmark). The open-loop ``push_into_region`` skill keeps
sweeping until every block is in, so it overshoots: only a monitor that halts it at the right count
succeeds (the paper's CLIPort column: 0 %).

Disturbances: none (the failure is the policy's own overshoot).
Expected failure signal: the count of block points inside the zone surface exceeds half.
Events: ``zone_count`` (``count``) each time the number of blocks inside changes; ``over_swept`` once, the
first time the zone holds more blocks than the success check accepts (``count`` > ``max_in_zone``; ``band`` =
[``min_in_zone``, ``max_in_zone``]; ``obj`` = ``"zone"``, ``objects`` = the zone and the blocks inside then).

Is an over-sweep final? No skill takes a block out of the zone: ``push_into_region`` only strokes blocks that
are outside towards the zone, and the kb planner stops once the band is exceeded. But a stroke into a full
zone shoves the pile, and blocks on its far side can leave the zone: the open-loop push keeps going after an
over-sweep and the count drifts down as well as up. In the round-2 records (``results/published/
cliport-round2.jsonl``, sweep-half) all 60 open-loop episodes exceeded 24 (peaks 32-38); by that drift 6 ended
in band at the time limit and 3 below it. So the event is the failure "if nothing is done" (a halted arm leaves
resting blocks where they are, and the policy's continuation fails 54 times in 60), and the metrics
(:func:`code_as_monitor.bench.metrics.failures`) treat an over-sweep like a drop that landed on its target
when the episode's final count is back in ``band``: logged, but it did not change the outcome.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError, SimError
from code_as_monitor.core.registry import check_positive
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult

SMALL = 0.02


def in_zone(xy: np.ndarray, center: np.ndarray, half: float) -> np.ndarray:
    """(N,) bool: which points ``xy`` (N, 2) lie inside the axis-aligned square of ``half`` size around ``center``
    (2,), table frame, metres (edges inclusive)."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    return np.all(np.abs(xy - np.asarray(center)[None]) <= half, axis=1)


def count_in_zone(xy: np.ndarray, center: np.ndarray, half: float) -> int:
    """Number of points ``xy`` (N, 2) inside the axis-aligned square of ``half`` size around ``center`` (2,)."""
    return int(np.sum(in_zone(xy, center, half)))


@TaskConfig.register("sweep-half")
@dataclass
class SweepHalfConfig(TaskConfig):
    """``n_blocks`` blocks; success when ``min_in_zone`` .. ``max_in_zone`` are in the zone (an ``instruction``
    sets the band: "push 10 blocks into the zone" -> 9 .. 11, see the kb's sweep family)."""

    time_limit: float = 30.0
    n_blocks: int = 40
    min_in_zone: int = 16
    max_in_zone: int = 24
    zone_half: float = 0.08

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 1 <= self.n_blocks <= 60:
            raise ConfigError(f"sweep-half.n_blocks must be in [1, 60], got {self.n_blocks!r}")
        if not 0 <= self.min_in_zone <= self.max_in_zone <= self.n_blocks:
            raise ConfigError(f"sweep-half: need 0 <= min_in_zone <= max_in_zone <= n_blocks, got "
                              f"{self.min_in_zone}, {self.max_in_zone}, {self.n_blocks}")
        check_positive("sweep-half", "zone_half", self.zone_half)

    def scene_objects(self) -> list[str]:
        return [f"block_{i:02d}" for i in range(self.n_blocks)] + ["zone", "table"]


def describe_band(lower: int, upper: int, n: int) -> str:
    """The instruction for a count band (the instruction grammar reads it back to the same band)."""
    if (lower, upper) == (math.ceil(0.4 * n), math.floor(0.6 * n)):
        return "sweep half of the blocks into the zone"
    if lower == upper:
        return f"push exactly {lower} of the {n} blocks into the zone"
    return f"push between {lower} and {upper} of the {n} blocks into the zone"


class SweepHalf(Task):
    ee_kind = "spatula"

    @property
    def instruction(self) -> str:  # type: ignore[override]
        cfg = self.config
        return cfg.instruction or describe_band(cfg.min_in_zone, cfg.max_in_zone, cfg.n_blocks)

    def __init__(self, config: SweepHalfConfig) -> None:
        super().__init__(config)
        self.config: SweepHalfConfig = config
        self.names = [f"block_{i:02d}" for i in range(config.n_blocks)]
        self._count = -1
        self._over_swept = False

    def load_scene(self, world) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        zone = pb.loadURDF(str(ASSETS / "zone.urdf"), [0.5, 0.2, 0.0], useFixedBase=True, physicsClientId=c)
        s = self.config.zone_half / 0.08
        if abs(s - 1.0) > 1e-9:  # the URDF is 16 cm; rebuild the visual at another size
            pb.removeBody(zone, physicsClientId=c)
            vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[self.config.zone_half] * 2 + [0.0005],
                                       rgbaColor=[0.95, 0.85, 0.2, 1], physicsClientId=c)
            zone = pb.createMultiBody(0, -1, vis, [0.5, 0.2, 0.0005], physicsClientId=c)
        world.add_object("zone", [zone], parts={"surface": (zone, -1)})
        for i, name in enumerate(self.names):
            b = pb.loadURDF(str(ASSETS / "small_block.urdf"), [0.2 + 0.03 * (i % 10), -0.6 - 0.03 * (i // 10),
                                                               SMALL / 2], physicsClientId=c)
            pb.changeDynamics(b, -1, lateralFriction=0.4, restitution=0.0,
                              activationState=pb.ACTIVATION_STATE_ENABLE_SLEEPING, physicsClientId=c)
            world.add_object(name, [b])

    def reset(self, world) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        center = np.array([0.5 + rng.uniform(-0.03, 0.03), 0.2 + rng.uniform(-0.03, 0.03)])
        pb.resetBasePositionAndOrientation(world.body_of("zone"), [*center, 0.0], [0, 0, 0, 1], physicsClientId=c)
        self.center = center
        pts: list[np.ndarray] = []
        lo = np.array([center[0] - 0.1, center[1] - self.config.zone_half - 0.31])
        while len(pts) < len(self.names):
            p = lo + rng.uniform([0.0, 0.0], [0.2, 0.26])
            if all(np.linalg.norm(p - q) >= 0.028 for q in pts):
                pts.append(p)
        for name, p in zip(self.names, pts):
            b = world.body_of(name)
            yaw = rng.uniform(0, np.pi / 2)
            pb.resetBasePositionAndOrientation(b, [*p, SMALL / 2], pb.getQuaternionFromEuler([0, 0, yaw]),
                                               physicsClientId=c)
            shade = rng.uniform(0.55, 0.95)
            pb.changeVisualShape(b, -1, rgbaColor=[shade, 0.35 * shade, 0.1, 1], physicsClientId=c)
        self._count = -1
        self._over_swept = False

    # --- region interface used by the push skill -----------------------------------------------------------
    def _check_region(self, region: str) -> None:
        if region != "zone":
            raise SimError(f"unknown region {region!r}; this task has: zone")

    def region_objects(self, region: str) -> list[str]:
        self._check_region(region)
        return list(self.names)

    def region_center(self, world, region: str) -> np.ndarray:
        self._check_region(region)
        return world.position("zone")[:2]

    def region_contains(self, world, region: str, xy: np.ndarray) -> bool:
        self._check_region(region)
        return count_in_zone(np.asarray(xy)[None], world.position("zone")[:2], self.config.zone_half) == 1

    def region_entry(self, world, region: str, start: np.ndarray, d: np.ndarray) -> np.ndarray:
        """(2,) first point of the ray ``start + s d`` (s >= 0) inside the region (``start`` if inside)."""
        c, h = self.region_center(world, region), self.config.zone_half
        s_in = 0.0
        for k in range(2):
            if abs(d[k]) < 1e-9:
                continue
            s1, _ = sorted(((c[k] - h - start[k]) / d[k], (c[k] + h - start[k]) / d[k]))
            s_in = max(s_in, s1)
        return np.asarray(start, dtype=float) + s_in * np.asarray(d, dtype=float)

    def inside(self, world) -> list[str]:
        """Names of the blocks whose centre is inside the zone now (the success check's count)."""
        import pybullet as pb

        xy = np.array([pb.getBasePositionAndOrientation(world.body_of(n), physicsClientId=world.client)[0][:2]
                       for n in self.names])
        mask = in_zone(xy, world.position("zone")[:2], self.config.zone_half)
        return [n for n, m in zip(self.names, mask) if m]

    def count(self, world) -> int:
        return len(self.inside(world))

    def on_tick(self, world) -> None:
        """Every second tick: ``zone_count`` when the count changed, and ``over_swept`` the first time it exceeds
        the config's ``max_in_zone`` (the same bound :meth:`evaluate` uses)."""
        if world.ticks % 2:
            return
        blocks = self.inside(world)
        n = len(blocks)
        if n != self._count:
            world.events.log(world.t, "zone_count", "zone", count=n)
            self._count = n
        cfg = self.config
        if n > cfg.max_in_zone and not self._over_swept:
            world.events.log(world.t, "over_swept", "zone", count=n, band=[cfg.min_in_zone, cfg.max_in_zone],
                             objects=["zone", *blocks])
            self._over_swept = True

    def evaluate(self, world) -> TaskResult:
        n = self.count(world)
        cfg = self.config
        ok = cfg.min_in_zone <= n <= cfg.max_in_zone
        reason = f"{n} blocks in the zone ({'within' if ok else 'outside'} {cfg.min_in_zone}..{cfg.max_in_zone})"
        return TaskResult(ok, reason, {"t": world.t, "count": n})

    def default_plan(self) -> list[Action]:
        return [Action("push_into_region", {"region": "zone"})]

    def settle_after_plan(self) -> bool:
        return False


SweepHalfConfig.task_class = SweepHalf
