"""``stow-book`` (line level, the paper's OmniGibson "Stow Book"): put the book upright into the bookshelf.

Description: a ``book`` (parts ``cover`` and ``spine``; 20 x 12 x 2.4 cm, its height along the local +x
axis, the spine a 1 cm strip along one long edge) lies flat on the table; a ``bookshelf`` (an open
cubby, inner 15 x 15 cm, 9 cm tall; parts ``body`` and ``slot``, the slot's rim) stands nearby.
Parallel-jaw gripper. Plan: ``grasp`` the book by its cover, ``reorient`` it spine-vertical, ``stow``
it into the shelf slot.

Randomisation: book centre x [0.40, 0.52], y [0.08, 0.18] m, heading uniform; shelf x [0.42, 0.52],
y [-0.22, -0.14] m, yaw uniform in [0, 90) degrees.

Success: the book stands vertically in the shelf: nothing holds it, its spine (local x) within
``MAX_TILT`` (20 degrees) of vertical, its centre inside the slot (in the shelf frame, within the inner
half-size 7.5 cm on both axes) and its lower end at least 2 cm below the slot's rim.

Disturbances (config ``disturbance``):
``none``; ``a`` / ``turn``: while the gripper descends to grasp (grasp point within 5 cm of the book's
centre) the book is turned 35-57 degrees about its centre (in 0.1 s), so the jaws end up across a skewed book;
``b`` / ``tilt``: in transport (the book upright in the gripper, 3 cm closer to the shelf than when it
became upright) an end-effector joint is perturbed: the book turns 31-46 degrees in the grasp about the
closing axis; ``c`` / ``knock``: after placement (released in the slot, the grasp point 3 cm away)
the book is laid flat on the table beside the shelf.
Expected failure signals: (a) the spine turned while the gripper approached (its direction changed);
(b) the held spine is no longer near vertical; (c) after the stow the spine is horizontal and not in
the slot.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.tasks.base import Task, TaskConfig, TaskResult
from code_as_monitor.sim.tasks.slot_pen import _gripper_near, _TransportCheck
from code_as_monitor.sim.triggered import Triggered, lay_flat, slide, turn_in_grasp

BOOK_HALF_HEIGHT = 0.10  # half the book's height along its local x, metres (assets/book.urdf)
BOOK_HALF_THICK = 0.012  # half its thickness (local z), metres
SLOT_INNER_HALF = 0.075  # metres (assets/bookshelf.urdf)
SLOT_FLOOR = 0.006  # floor plate thickness, metres
SLOT_TOP = 0.09  # shelf height (top of the slot's rim), metres
MAX_TILT = np.radians(20.0)  # a stowed book's spine within 20 degrees of vertical
DISTURBANCES = {"none": "none", "a": "turn", "b": "tilt", "c": "knock",
                "turn": "turn", "tilt": "tilt", "knock": "knock"}


def book_in_shelf(book_pose: np.ndarray, shelf_pose: np.ndarray, held: bool) -> tuple[bool, str]:
    """Does the book stand vertically in the shelf? ``book_pose`` (4, 4) the book's (cover) pose, its
    local x the spine; ``shelf_pose`` (4, 4) the shelf's base pose (bottom centre); ``held``: still gripped."""
    if held:
        return False, "the book is still held"
    spine = np.asarray(book_pose, float)[:3, 0]
    tilt = float(np.degrees(np.arccos(min(1.0, abs(spine[2]) / max(float(np.linalg.norm(spine)), 1e-9)))))
    local = shelf_pose[:3, :3].T @ (np.asarray(book_pose, float)[:3, 3] - shelf_pose[:3, 3])
    off = float(np.max(np.abs(local[:2])))
    if off > SLOT_INNER_HALF:
        return False, f"the book's centre is {off * 100:.1f} cm off the slot's centre (not in the shelf)"
    low = local[2] - BOOK_HALF_HEIGHT * abs(float(spine[2])) / max(float(np.linalg.norm(spine)), 1e-9)
    if low > SLOT_TOP - 0.02:
        return False, f"the book's lower end is {low * 100:.1f} cm above the shelf floor: not in the slot"
    if tilt > np.degrees(MAX_TILT):
        return False, f"the book's spine is {tilt:.0f} degrees from vertical: not standing"
    return True, f"the book stands in the shelf (spine {tilt:.0f} degrees from vertical)"


@TaskConfig.register("stow-book")
@dataclass
class StowBookConfig(TaskConfig):
    """``disturbance``: none, a (turn), b (tilt) or c (knock)."""

    time_limit: float = 60.0
    disturbance: str = "none"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.disturbance not in DISTURBANCES:
            raise ConfigError(f"stow-book.disturbance must be one of {', '.join(DISTURBANCES)}; "
                              f"got {self.disturbance!r}")


class StowBook(Task):
    ee_kind = "gripper"
    instruction = "put the book upright into the bookshelf"
    holder_floor = SLOT_FLOOR

    def __init__(self, config: StowBookConfig) -> None:
        super().__init__(config)
        self.config: StowBookConfig = config

    def load_scene(self, world: Any) -> None:
        import pybullet as pb

        from code_as_monitor.sim.world import ASSETS

        c = world.client
        book = pb.loadURDF(str(ASSETS / "book.urdf"), [0.5, 0.12, BOOK_HALF_THICK], physicsClientId=c)
        shelf = pb.loadURDF(str(ASSETS / "bookshelf.urdf"), [0.5, -0.15, 0.0], physicsClientId=c)
        for b in (book, shelf):
            for link in (-1, 0):
                pb.changeDynamics(b, link, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        world.add_object("book", [book], parts={"cover": (book, -1), "spine": (book, 0)}, graspable=True)
        world.add_object("bookshelf", [shelf], parts={"body": (shelf, -1), "slot": (shelf, 0)})

    def reset(self, world: Any) -> None:
        import pybullet as pb

        rng, c = world.rng, world.client
        book_xy = [rng.uniform(0.40, 0.52), rng.uniform(0.08, 0.18)]
        heading = rng.uniform(-np.pi, np.pi)
        shelf_xy = [rng.uniform(0.42, 0.52), rng.uniform(-0.22, -0.14)]
        pb.resetBasePositionAndOrientation(world.body_of("book"), [*book_xy, BOOK_HALF_THICK],
                                           pb.getQuaternionFromEuler([0, 0, heading]), physicsClientId=c)
        pb.resetBasePositionAndOrientation(world.body_of("bookshelf"), [*shelf_xy, 0.0],
                                           pb.getQuaternionFromEuler([0, 0, rng.uniform(0, np.pi / 2)]),
                                           physicsClientId=c)

    # --- interface used by the gripper skills ------------------------------------------------------
    def lowest_point(self, world: Any, obj: str) -> np.ndarray:
        """(3,) the centre of the book's end that goes into the slot first (its local +x end)."""
        T = world.pose(obj)
        return T[:3, 3] + T[:3, 0] * BOOK_HALF_HEIGHT

    def evaluate(self, world: Any) -> TaskResult:
        book, shelf = world.pose("book"), world.pose("bookshelf")
        held = world.robot.ee.holding == world.body_of("book")
        ok, reason = book_in_shelf(book, shelf, held)
        info = {"t": world.t, "book": book[:3, 3].tolist(), "spine": book[:3, 0].tolist(),
                "shelf": shelf[:3, 3].tolist()}
        if ok and world.t > self.config.time_limit + 1e-9:
            ok, reason = False, f"stowed after the time limit ({world.t:.1f} s)"
        return TaskResult(ok, reason, info)

    def placed(self, world: Any, obj: str, target: str) -> tuple[bool, str] | None:
        """The book let go into the shelf stands in it (the success test, nothing held)."""
        if obj != "book" or target != "bookshelf":
            return None
        return book_in_shelf(world.pose("book"), world.pose("bookshelf"), held=False)

    def default_plan(self) -> list[Action]:
        return [
            Action("grasp", {"obj": "book", "part": "cover"}),
            Action("reorient", {"obj": "book", "axis": "vertical"}),
            Action("stow", {"obj": "book", "target": "bookshelf"}),
        ]

    # --- disturbances --------------------------------------------------------------------------------
    def disturbances(self, seed: int = 0) -> list[Any]:
        kind = DISTURBANCES[self.config.disturbance]
        if kind == "turn":
            turn = slide("book", (0.0, 0.005), (0.6, 1.0), duration=0.1)
            return [Triggered(kind, _gripper_near("book"), turn, [seed, 21])]
        if kind == "tilt":
            return [Triggered(kind, _TransportCheck("book", "bookshelf"), turn_in_grasp((0.55, 0.8), axis=0),
                              [seed, 22])]
        if kind == "knock":
            return [Triggered(kind, _placed, lay_flat("book", _beside_shelf, roll=0.0, z=BOOK_HALF_THICK + 0.001),
                              [seed, 23])]
        return []


def _placed(world: Any) -> bool:
    """Condition: the book is released in the slot and the grasp point is 3 cm away from its centre."""
    ee = world.robot.ee
    if ee.holding is not None or ee.active:
        return False
    book = world.position("book")
    if float(np.linalg.norm(book[:2] - world.position("bookshelf")[:2])) > SLOT_INNER_HALF:
        return False
    return float(np.linalg.norm(world.robot.tip() - book)) > 0.03


def _beside_shelf(world: Any) -> np.ndarray:
    """(3,) horizontal shift from the stowed book to a free spot of table on the robot's side of the shelf."""
    side = 1.0 if world.position("bookshelf")[1] < 0 else -1.0
    target = world.position("bookshelf")[:2] + np.array([0.0, 0.21 * side])
    return np.array([*(target - world.position("book")[:2]), 0.0])


StowBookConfig.task_class = StowBook
