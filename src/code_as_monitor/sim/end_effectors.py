"""End-effectors: as in CLIPort a suction cup (pick, place, stack) and a spatula (push), plus a
parallel-jaw gripper (grasp, reorient, insert, pour, pull).

A tool is its own body (``assets/suction.urdf`` / ``assets/spatula.urdf``) fixed to the Panda's
grasp frame by a stiff fixed constraint. Its frame's +z axis is the approach direction (down when
the arm points down); the *tip* lies ``tip_length`` metres along +z.

Suction: ``activate()`` attaches the nearest graspable body within ``contact_tol`` of the cup with a
fixed constraint that keeps their relative pose (CLIPort's model); ``release()`` removes it. The
suction stays "on" (``RobotState.gripper == 1``) after a drop disturbance detaches the object: the
open-loop policy does not know it lost the block.

Gripper (:class:`Gripper`, ``assets/gripper.urdf``): two fingers on prismatic joints closing along the
tool's x axis, grasp point (tip) 6 cm along +z. Design choice: a *closed grasp is a fixed
constraint*, not a friction grip. ``close()`` closes the fingers and, when the grasp point lies
inside (within ``grasp_tol``) the bounding box of a graspable body's link, fixes that body (or, for a
fixed-base articulated body such as a drawer, that link) to the tool at their current relative pose;
the fingers visually close to the grasped link's width. ``open()`` opens the fingers and removes
the constraint. The tool has no collision shapes, so it never shoves the object it approaches. Like
the suction, a disturbance can ``detach()`` the object while the fingers stay closed
(``RobotState.gripper == 1``): the open-loop policy does not know. The gripper also *tilts*: its
pitch about the closing axis is commanded with its yaw (``Panda.ik``), so a held pen or book can be
turned upright and a teapot tilted.
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

    tilts = False
    """True when the tool's pitch is commanded (the gripper); otherwise the tool always points down."""


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

    def touching(self, graspable: list[int]) -> int | None:
        """The closest body of ``graspable`` within ``contact_tol`` of the cup, or None."""
        import pybullet as pb

        best, best_d = None, self.contact_tol
        for b in graspable:
            for cp in pb.getClosestPoints(self.body, b, self.contact_tol, physicsClientId=self.client):
                if cp[8] <= best_d:
                    best, best_d = b, cp[8]
        return best

    def activate(self, graspable: list[int]) -> int | None:
        """Switch suction on; attach the closest body of ``graspable`` in contact. Returns it or None."""
        import pybullet as pb

        c = self.client
        self.active = True
        if self._held is not None:
            return self._held
        best = self.touching(graspable)
        if best is None:
            return None
        tpos, torn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        opos, oorn = pb.getBasePositionAndOrientation(best, physicsClientId=c)
        ipos, iorn = pb.invertTransform(tpos, torn)
        rpos, rorn = pb.multiplyTransforms(ipos, iorn, opos, oorn)
        self.attach(best, rpos, rorn)
        return best

    def attach(self, body: int, rel_pos, rel_orn, link: int = -1) -> None:
        """Fix ``body`` (its ``link``; -1 the base) to the tool at relative pose (``rel_pos`` metres,
        ``rel_orn`` quaternion, the object's frame in the tool's frame)."""
        import pybullet as pb

        c = self.client
        self._constraint = pb.createConstraint(self.body, -1, body, link, pb.JOINT_FIXED, [0, 0, 0], rel_pos,
                                               [0, 0, 0], parentFrameOrientation=rel_orn, physicsClientId=c)
        pb.changeConstraint(self._constraint, maxForce=self.hold_force, physicsClientId=c)
        self._held, self._rel, self._link = body, (tuple(rel_pos), tuple(rel_orn)), link

    hold_force = 100.0
    """Newtons: the attachment constraint's maximum force."""
    _link = -1

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


class Gripper(Suction):
    """Parallel-jaw gripper; a closed grasp is a fixed constraint (see the module docstring).

    It shares the suction's attachment bookkeeping (``holding``, ``attach``, ``detach``,
    ``attachment``) so the world's save/restore and the drop disturbances work unchanged.
    """

    kind = "gripper"
    urdf = "gripper.urdf"
    tip_length = 0.06
    grasp_tol = 0.01  # metres the grasp point may lie outside a link's bounding box
    open_width = 0.04  # per finger, metres from the centre
    pad_clearance = 0.01
    """Metres each finger stops short of a grasped fixed-base link (a handle bar). With the fingers set right
    at the bar, the fixed-constraint grasp of an articulated link turned compliant in PyBullet (a pulled
    drawer lagged the tool by 1-4 cm, measured; the fingers carry no collision shapes, so this is a solver
    artefact we did not get to the bottom of); 1 cm off, the lag is a few millimetres."""
    tilts = True
    hold_force = 200.0

    def load(self, robot_body: int, link: int) -> None:
        super().load(robot_body, link)
        self._fingers(self.open_width)

    def _fingers(self, half_width: float) -> None:
        import pybullet as pb

        pb.setJointMotorControlArray(self.body, [0, 1], pb.POSITION_CONTROL, targetPositions=[half_width] * 2,
                                     forces=[20.0, 20.0], physicsClientId=self.client)

    def grasp_point(self) -> np.ndarray:
        """(3,) world position of the grasp point (the tool tip)."""
        import pybullet as pb

        pos, orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=self.client)
        R = np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))
        return np.asarray(pos) + R[:, 2] * self.tip_length

    def close(self, graspable: list[int]) -> tuple[int, int] | None:
        """Close the fingers; grasp the graspable link around the grasp point. Returns (body, link) or None."""
        import pybullet as pb

        c = self.client
        self.active = True
        if self._held is not None:
            return self._held, self._link
        p = self.grasp_point()
        best, best_d = None, np.inf
        for b in graspable:
            for link in range(-1, pb.getNumJoints(b, physicsClientId=c)):
                lo, hi = (np.asarray(v) for v in pb.getAABB(b, link, physicsClientId=c))
                if np.all(p >= lo - self.grasp_tol) and np.all(p <= hi + self.grasp_tol):
                    d = float(np.linalg.norm(p - (lo + hi) / 2))
                    if d < best_d:
                        best, best_d = (b, link, lo, hi), d
        if best is None:
            self._fingers(0.0)
            return None
        b, link, lo, hi = best
        fixed_base = pb.getDynamicsInfo(b, -1, physicsClientId=c)[0] == 0.0
        at = link if fixed_base else -1
        tpos, torn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        if at < 0:
            opos, oorn = pb.getBasePositionAndOrientation(b, physicsClientId=c)
        else:
            opos, oorn = pb.getLinkState(b, at, computeForwardKinematics=True, physicsClientId=c)[:2]
        ipos, iorn = pb.invertTransform(tpos, torn)
        rpos, rorn = pb.multiplyTransforms(ipos, iorn, opos, oorn)
        self.attach(b, rpos, rorn, at)
        x_axis = np.reshape(pb.getMatrixFromQuaternion(torn), (3, 3))[:, 0]
        half = _half_extent_along(c, b, link, x_axis) if at >= 0 else None
        if half is None:  # a free body (or not all boxes): the world bounding box's extent along the closing axis
            half = float(np.abs(x_axis) @ (hi - lo) / 2)
        else:  # a link of a fixed-base body (a handle): its own width, plus the pads' clearance
            half += self.pad_clearance
        self._fingers(float(np.clip(half, 0.0, self.open_width)))
        return b, at

    def finger_points(self) -> dict[str, np.ndarray]:
        """World positions (3,) of the fingers at the grasp point's depth, ``finger_left`` / ``finger_right``:
        the tool tip moved out along the closing axis by each finger's joint position. Their distance is the
        jaw opening (8 cm open, closed on a handle its width plus 2 ``pad_clearance``, 0 closed on nothing);
        proprioception."""
        import pybullet as pb

        c = self.client
        pos, orn = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        R = np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))
        q = [s[0] for s in pb.getJointStates(self.body, [0, 1], physicsClientId=c)]
        tip = np.asarray(pos) + R[:, 2] * self.tip_length
        return {"finger_left": tip + R[:, 0] * q[0], "finger_right": tip - R[:, 0] * q[1]}

    def attachment(self) -> tuple | None:
        """(body, rel_pos, rel_orn, link) of the grasped object, or None (for save/restore)."""
        return None if self._held is None else (self._held, *self._rel, self._link)

    def open(self) -> int | None:
        """Open the fingers and let go. Returns the body that was held."""
        self._fingers(self.open_width)
        self.active = False
        return self.detach()

    def activate(self, graspable: list[int]) -> int | None:  # the suction-compatible name
        got = self.close(graspable)
        return None if got is None else got[0]

    def release(self) -> int | None:
        return self.open()


def _half_extent_along(client: int, body: int, link: int, axis: np.ndarray) -> float | None:
    """Half the extent (metres) of ``body``'s ``link`` along the world direction ``axis`` (3,), from its
    collision boxes in their own orientation (a yawed bar is as thin as it is, unlike its world bounding
    box) and spheres (their radius: a ball is as wide every way). Other shapes (PyBullet loads a URDF
    cylinder as a mesh) are left out when a box or a sphere is there (a lamp's neck under its ball, a tap's
    hub beside its lever); None when there is none."""
    import pybullet as pb

    shapes = [sh for sh in pb.getCollisionShapeData(body, link, physicsClientId=client)
              if sh[2] in (pb.GEOM_BOX, pb.GEOM_SPHERE)]
    if not shapes:
        return None
    if link < 0:
        fpos, forn = pb.getBasePositionAndOrientation(body, physicsClientId=client)
    else:
        fpos, forn = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)[:2]
    lo, hi = np.inf, -np.inf
    for sh in shapes:  # the shape frames are given in the link's inertial frame
        pos, orn = pb.multiplyTransforms(fpos, forn, sh[5], sh[6])
        if sh[2] == pb.GEOM_SPHERE:
            half = float(sh[3][0])
        else:
            R = np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))
            half = float(np.abs(R.T @ axis) @ np.asarray(sh[3]) / 2)
        centre = float(np.dot(pos, axis))
        lo, hi = min(lo, centre - half), max(hi, centre + half)
    return (hi - lo) / 2


def make_end_effector(kind: str, client: int) -> EndEffector:
    from code_as_monitor.core.errors import SimError

    if kind == "suction":
        return Suction(client)
    if kind == "spatula":
        return Spatula(client)
    if kind == "gripper":
        return Gripper(client)
    raise SimError(f"unknown end-effector {kind!r}; choose suction, spatula or gripper")


def tip_offset(kind: str) -> np.ndarray:
    lengths = {"suction": Suction.tip_length, "spatula": Spatula.tip_length, "gripper": Gripper.tip_length}
    return np.array([0.0, 0.0, lengths[kind]])
