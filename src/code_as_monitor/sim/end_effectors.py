"""End-effectors as in CLIPort: a suction cup (pick, place, stack) and a spatula (push).

A tool is its own body (``assets/suction.urdf`` / ``assets/spatula.urdf``) fixed to the Panda's
grasp frame by a stiff fixed constraint. Its frame's +z axis is the approach direction (down when
the arm points down); the *tip* lies ``tip_length`` metres along +z.

Suction: ``activate()`` attaches the nearest graspable body within ``contact_tol`` of the cup with a
fixed constraint that keeps their relative pose (CLIPort's model); ``release()`` removes it. The
suction stays "on" (``RobotState.gripper == 1``) after a drop disturbance detaches the object: the
open-loop policy does not know it lost the block.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

ASSETS = Path(__file__).parent / "assets"


class EndEffector:
    """Base tool: a body fixed to the robot's grasp link."""

    kind = "none"
    urdf = ""
    tip_length = 0.0

    def __init__(self, client: int) -> None:
        self.client = client
        self.body = -1
        self.active = False

    def load(self, robot_body: int, link: int) -> None:
        """Create the tool at the grasp link's pose and fix it there."""
        import pybullet as pb

        c = self.client
        pos, orn = pb.getLinkState(robot_body, link, computeForwardKinematics=True, physicsClientId=c)[4:6]
        self.body = pb.loadURDF(str(ASSETS / self.urdf), pos, orn, physicsClientId=c)
        cid = pb.createConstraint(robot_body, link, self.body, -1, pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0],
                                  [0, 0, 0], physicsClientId=c)
        pb.changeConstraint(cid, maxForce=2000, physicsClientId=c)
        for j in range(-1, pb.getNumJoints(robot_body, physicsClientId=c)):
            pb.setCollisionFilterPair(robot_body, self.body, j, -1, 0, physicsClientId=c)

    @property
    def holding(self) -> int | None:
        return None

    def gripper_value(self) -> float:
        return 1.0 if self.active else 0.0


class Suction(EndEffector):
    """Suction cup: a fixed constraint to the touched object while active."""

    kind = "suction"
    urdf = "suction.urdf"
    tip_length = 0.06
    contact_tol = 0.006  # metres between the cup and an object's surface to count as contact

    def __init__(self, client: int) -> None:
        super().__init__(client)
        self._constraint: int | None = None
        self._held: int | None = None
        self._rel: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))

    @property
    def holding(self) -> int | None:
        """Body id of the attached object, or None."""
        return self._held

    def activate(self, graspable: list[int]) -> int | None:
        """Switch suction on; attach the closest body of ``graspable`` in contact. Returns it or None."""
        import pybullet as pb

        c = self.client
        self.active = True
        if self._held is not None:
            return self._held
        best, best_d = None, self.contact_tol
        for b in graspable:
            for cp in pb.getClosestPoints(self.body, b, self.contact_tol, physicsClientId=c):
                if cp[8] <= best_d:
                    best, best_d = b, cp[8]
        if best is None:
            return None
        tpos, torn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        opos, oorn = pb.getBasePositionAndOrientation(best, physicsClientId=c)
        ipos, iorn = pb.invertTransform(tpos, torn)
        rpos, rorn = pb.multiplyTransforms(ipos, iorn, opos, oorn)
        self.attach(best, rpos, rorn)
        return best

    def attach(self, body: int, rel_pos, rel_orn) -> None:
        """Fix ``body`` to the cup at relative pose (``rel_pos`` metres, ``rel_orn`` quaternion)."""
        import pybullet as pb

        c = self.client
        self._constraint = pb.createConstraint(self.body, -1, body, -1, pb.JOINT_FIXED, [0, 0, 0], rel_pos,
                                               [0, 0, 0], parentFrameOrientation=rel_orn, physicsClientId=c)
        pb.changeConstraint(self._constraint, maxForce=100, physicsClientId=c)
        self._held, self._rel = body, (tuple(rel_pos), tuple(rel_orn))

    def attachment(self) -> tuple | None:
        """(body, rel_pos, rel_orn) of the attached object, or None (for save/restore)."""
        return None if self._held is None else (self._held, *self._rel)

    def detach(self) -> int | None:
        """Drop the attached object (suction stays on). Returns the body that was held."""
        import pybullet as pb

        held = self._held
        if self._constraint is not None:
            pb.removeConstraint(self._constraint, physicsClientId=self.client)
        self._constraint, self._held = None, None
        return held

    def release(self) -> int | None:
        """Switch suction off and detach. Returns the body that was held."""
        self.active = False
        return self.detach()


class Spatula(EndEffector):
    """Spatula: a rigid blade for pushing; no activation state."""

    kind = "spatula"
    urdf = "spatula.urdf"
    tip_length = 0.10


def make_end_effector(kind: str, client: int) -> EndEffector:
    from code_as_monitor.core.errors import SimError

    if kind == "suction":
        return Suction(client)
    if kind == "spatula":
        return Spatula(client)
    raise SimError(f"unknown end-effector {kind!r}; choose suction or spatula")


def tip_offset(kind: str) -> np.ndarray:
    return np.array([0.0, 0.0, {"suction": Suction.tip_length, "spatula": Spatula.tip_length}[kind]])
