"""``stack-in-order``: stack red (bottom), green (middle), blue (top), or the tower an instruction asks for.

Description: three 4 cm blocks (``red_block``, ``green_block``, ``blue_block``; parts ``body`` and
``top``) lie on the table; the robot (suction cup) must build the tower red-green-blue (config ``order``,
bottom first; two or three blocks; ``any_order`` accepts any order of them; ``instruction`` sets both).

Randomisation: block positions uniform in x [0.35, 0.65], y [-0.25, 0.25] m (pairwise >= 10 cm
apart), yaw uniform in [0, 90) degrees.

Success (default order): red on the table, green resting on red and blue on green, each centred within
half a block (2 cm) horizontally of the one below and at the right height (+-1 cm), nothing held, within
``time_limit`` (70 s) of sim time; for another ``order`` the same test over its blocks.

Disturbances (config fields): ``p`` drop probability per drop decision. In CLIPort a "step" is a
primitive-level action step, not a physics tick, so a decision is taken every ``1 / drop_check_hz``
s of holding; the default 2 Hz gives about two decisions per ~1.2 s carry (four per episode; a drop
during the final descent usually still lands on the tower). ``q``: placement noise in cm (offset of
uniform direction, magnitude uniform in [0, q] cm). ``xy_tol_cm`` (1 cm, CLIPort's position
tolerance ``pos_eps``) is how far a block may sit off the centre of the one below.
Physics: block friction 0.5, restitution 0, 0.1 kg, 20 solver iterations; a block placed more than
~2 cm off-centre overhangs its centre of mass and topples, offsets compound over two placements.
Measured open-loop success (benchmarks/open_loop_success.py, 5 seeds x 12 episodes), paper's
CLIPort column in brackets: p=0 100 % (100), p=0.15 63 % (57), p=0.3 28 % (22), q=1 93 % (90),
q=2 25 % (42), q=3 7 % (15).

Expected failure signals: after a drop the carried block is no longer under the suction tip (it
lies on the table, ``block_fell``); after noisy placement the upper block's centre is offset from the
lower one's, and a collapse (``tower_collapsed``) leaves a block at table height.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np

from code_as_monitor.core.checks import check_range
from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.registry import check_positive, check_probability
from code_as_monitor.sim.disturbances import Disturbance, DropConfig, PlacementNoiseConfig
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult

BLOCK = 0.04  # block edge, metres
ORDER = ("red_block", "green_block", "blue_block")
Q_MAX_CM = 50.0
"""Largest placement noise bound accepted, cm (larger values are refused as typos, not simulated)."""
COLORS = {"red_block": (0.85, 0.15, 0.15, 1), "green_block": (0.15, 0.75, 0.2, 1), "blue_block": (0.15, 0.3, 0.9, 1)}
TOP_TINT = 0.12


def tower_in_order(pos: dict[str, np.ndarray], size: float = BLOCK, xy_tol: float | None = None,
                   z_tol: float = 0.01, order: tuple[str, ...] = ORDER) -> tuple[bool, str]:
    """Is ``pos`` (block name -> (3,) centre, metres) a tower of ``order`` (bottom first) standing on z = 0?"""
    xy_tol = size / 2 if xy_tol is None else xy_tol
    for level, name in enumerate(order):
        p = np.asarray(pos[name], dtype=float)
        want_z = size / 2 + level * size
        if abs(p[2] - want_z) > z_tol:
            return False, f"{name} is at height {p[2]:.3f} m, expected {want_z:.3f} m"
        if level:
            below = np.asarray(pos[order[level - 1]], dtype=float)
            off = float(np.linalg.norm(p[:2] - below[:2]))
            if off > xy_tol:
                return False, f"{name} is {off * 100:.1f} cm off the centre of {order[level - 1]}"
    return True, "tower in order"


def describe_tower(order: tuple[str, ...], any_order: bool = False) -> str:
    """The instruction for a tower goal (the instruction grammar reads it back to the same goal)."""
    names = [n.removesuffix("_block") for n in order]
    if any_order:
        return f"stack the {', '.join(names[:-1])} and {names[-1]} blocks in any order"
    if len(names) == 2:
        return f"put the {names[1]} block on the {names[0]} block"
    return "stack the blocks: " + ", then ".join([f"{names[0]} at the bottom", *names[1:]])


@TaskConfig.register("stack-in-order")
@dataclass
class StackInOrderConfig(TaskConfig):
    """``p``: drop probability per decision; ``q``: placement noise, cm; ``drop_check_hz``: decisions/s.

    Goal: ``order``, the tower's blocks bottom first (two or three of red_block, green_block, blue_block);
    ``any_order``: any order of those blocks succeeds. An ``instruction`` sets both (see TaskConfig)."""

    time_limit: float = 70.0
    p: float = 0.0
    q: float = 0.0
    drop_check_hz: float = 2.0
    xy_tol_cm: float = 1.0
    order: tuple[str, ...] = ORDER
    any_order: bool = False

    def scene_objects(self) -> list[str]:
        return [*ORDER, "table"]

    def __post_init__(self) -> None:
        self.order = tuple(self.order)
        super().__post_init__()
        self.order = tuple(self.order)
        if len(self.order) < 2 or len(set(self.order)) != len(self.order) or not set(self.order) <= set(ORDER):
            raise ConfigError(f"stack-in-order.order must be two or three different blocks of {', '.join(ORDER)}, "
                              f"got {list(self.order)!r}")
        check_positive("stack-in-order", "xy_tol_cm", self.xy_tol_cm)
        check_probability("stack-in-order", "p", self.p)
        check_range("stack-in-order", "q", self.q, 0.0, Q_MAX_CM)
        check_positive("stack-in-order", "drop_check_hz", self.drop_check_hz)


class StackInOrder(Task):
    ee_kind = "suction"

    def __init__(self, config: StackInOrderConfig) -> None:
        super().__init__(config)
        self.config: StackInOrderConfig = config
        self._stacked: dict[str, float] = {}

    @property
    def instruction(self) -> str:  # type: ignore[override]
        return self.config.instruction or describe_tower(self.config.order, self.config.any_order)

    def load_scene(self, world) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        for i, name in enumerate(ORDER):
            b = pb.loadURDF(str(ASSETS / "block.urdf"), [0.3 + 0.1 * i, 0.6, BLOCK / 2], physicsClientId=c)
            rgba = COLORS[name]
            top = (*(min(1.0, v + TOP_TINT) for v in rgba[:3]), 1.0)
            pb.changeVisualShape(b, -1, rgbaColor=rgba, physicsClientId=c)
            pb.changeVisualShape(b, 0, rgbaColor=top, physicsClientId=c)
            for link in (-1, 0):
                pb.changeDynamics(b, link, lateralFriction=0.5, restitution=0.0, spinningFriction=0.001,
                                  physicsClientId=c)
            world.add_object(name, [b], parts={"body": (b, -1), "top": (b, 0)}, graspable=True)

    def reset(self, world) -> None:
        import pybullet as pb

        rng = world.rng
        placed: list[np.ndarray] = []
        while len(placed) < len(ORDER):
            xy = np.array([rng.uniform(0.35, 0.65), rng.uniform(-0.25, 0.25)])
            if all(np.linalg.norm(xy - q) >= 0.10 for q in placed):
                placed.append(xy)
        for name, xy in zip(ORDER, placed):
            yaw = rng.uniform(0.0, np.pi / 2)
            pb.resetBasePositionAndOrientation(world.body_of(name), [*xy, BLOCK / 2],
                                               pb.getQuaternionFromEuler([0, 0, yaw]), physicsClientId=world.client)
        self._stacked = {}

    def on_tick(self, world) -> None:
        if world.ticks % 4:
            return
        import pybullet as pb

        held = world.robot.ee.holding
        for name in ORDER:
            b = world.body_of(name)
            if b == held:
                self._stacked.pop(name, None)
                continue
            z = pb.getBasePositionAndOrientation(b, physicsClientId=world.client)[0][2]
            v = np.linalg.norm(pb.getBaseVelocity(b, physicsClientId=world.client)[0])
            if name in self._stacked and z < self._stacked[name] - BLOCK / 2:
                pos = world.position(name)
                world.events.log(world.t, "tower_collapsed", name, pos=pos.tolist(), from_z=self._stacked[name])
                del self._stacked[name]
            elif z > BLOCK * 1.25 and v < 0.05:  # resting or just released on top of another block
                self._stacked[name] = max(z, self._stacked.get(name, 0.0))

    def evaluate(self, world) -> TaskResult:
        pos = {n: world.position(n) for n in ORDER}
        orders = list(permutations(self.config.order)) if self.config.any_order else [self.config.order]
        for order in orders:
            ok, reason = tower_in_order(pos, xy_tol=self.config.xy_tol_cm / 100.0, order=tuple(order))
            if ok:
                break
        if not ok and len(orders) > 1:
            reason = f"no order of {', '.join(self.config.order)} stands as a tower ({reason})"
        info = {"t": world.t, "positions": {n: p.tolist() for n, p in pos.items()}}
        if ok and world.robot.ee.holding is not None:
            ok, reason = False, f"{world.name_of(world.robot.ee.holding)} is still held"
        if ok and world.t > self.config.time_limit + 1e-9:
            ok, reason = False, f"tower built after the time limit ({world.t:.1f} s > {self.config.time_limit} s)"
        return TaskResult(ok, reason, info)

    def default_plan(self) -> list[Action]:
        plan: list[Action] = []
        for below, block in zip(self.config.order, self.config.order[1:]):
            plan += [Action("pick", {"obj": block}), Action("place_on", {"obj": block, "target": below})]
        return plan

    def disturbances(self, seed: int = 0) -> list[Disturbance]:
        out: list[Disturbance] = []
        if self.config.p > 0:
            out.append(DropConfig(p=self.config.p, check_hz=self.config.drop_check_hz,
                                  landing_tol=self.config.xy_tol_cm / 100.0).build([seed, 1]))
        if self.config.q > 0:
            out.append(PlacementNoiseConfig(q=self.config.q).build([seed, 2]))
        return out


StackInOrderConfig.task_class = StackInOrder
