"""The Franka Panda from ``pybullet_data``, driven by inverse kinematics on the tool tip.

Poses are commanded as a tool-tip position (world, metres), a yaw about the world z axis (radians)
and a pitch (radians, default 0) about the tool's own x axis: pitch 0 points the tool straight down,
pitch pi/2 points it horizontally (only the gripper tilts; see ``EndEffector.tilts``). Joint position
motors track the IK solution.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.sim.end_effectors import EndEffector, make_end_effector

ARM_JOINTS = list(range(7))
FINGER_JOINTS = (9, 10)
GRASP_LINK = 11  # panda_grasptarget
HOME_Q = [-0.8, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]  # parked to the side: cameras see the workspace
ARM_FORCES = [240.0, 240.0, 240.0, 240.0, 60.0, 60.0, 60.0]


def down_quat(yaw: float, pitch: float = 0.0) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a tool pointing down (+z of the tool = world -z), rotated by ``yaw``
    about world z, then tilted by ``pitch`` about its own x axis: Rz(yaw) Rx(pi) Rx(pitch)."""
    import pybullet as pb

    return tuple(pb.getQuaternionFromEuler([np.pi + float(pitch), 0.0, float(yaw)]))


def pose_matrix(pos, orn) -> np.ndarray:
    """(4, 4) pose from a position (3,) and a quaternion (x, y, z, w)."""
    import pybullet as pb

    T = np.eye(4)
    T[:3, :3] = np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))
    T[:3, 3] = pos
    return T


ROBOT_VISUALS = ("decimated", "mesh", "hull")
DEFAULT_ROBOT_VISUAL = "decimated"
"""What cameras see of the arm unless told otherwise (see :func:`panda_urdf`)."""
DECIMATED_KEEP = 0.1
"""Share of the visual meshes' triangles the ``"decimated"`` arm keeps (see :mod:`code_as_monitor.sim.robot_meshes`)."""


def check_robot_visual(owner: str, visual: object) -> None:
    """ConfigError naming ``owner``'s ``robot_visual`` unless it is one of :data:`ROBOT_VISUALS`."""
    from code_as_monitor.core.errors import ConfigError

    if visual not in ROBOT_VISUALS:
        raise ConfigError(f"{owner}.robot_visual must be one of {', '.join(ROBOT_VISUALS)}, got {visual!r}")


def panda_urdf(visual: str = DEFAULT_ROBOT_VISUAL) -> str:
    """Path of the Panda URDF with the given visual geometry (what cameras see; physics is the same).

    ``"mesh"``: ``pybullet_data``'s own file, its detailed visual meshes (about 100k triangles, two
    thirds of a 320x240 TinyRenderer frame's cost). ``"decimated"`` (the default): the same meshes with
    about a fifth of their triangles (:mod:`code_as_monitor.sim.robot_meshes`; their colours and materials
    kept; measured by ``benchmarks/robot_visual_fidelity.py``: under 1 % of the arm's pixels change label,
    about 40 % less render time). ``"hull"``: the same robot drawn with its collision meshes (about 3k triangles,
    plain white). The two variants are files written once to a cache directory (the temporary directory),
    with absolute mesh paths; a process finds its file again without re-reading the sources.
    """
    import hashlib
    import os
    import tempfile

    import pybullet_data

    from code_as_monitor.core.errors import ConfigError

    if visual not in ROBOT_VISUALS:
        raise ConfigError(f"robot visual must be one of {', '.join(ROBOT_VISUALS)}, got {visual!r}")
    root = os.path.join(pybullet_data.getDataPath(), "franka_panda")
    urdf = os.path.join(root, "panda.urdf")
    if visual == "mesh":
        return urdf
    known = _URDF_PATHS.get((visual, tempfile.gettempdir()))
    if known is not None and os.path.exists(known):
        return known
    with open(urdf, encoding="utf-8") as fh:
        text = fh.read()
    if visual == "hull":
        text = text.replace("package://meshes/visual/", "package://meshes/collision/")
    else:
        from code_as_monitor.sim.robot_meshes import decimated_visual_dir

        text = text.replace("package://meshes/visual/",
                            decimated_visual_dir(os.path.join(root, "meshes", "visual"), DECIMATED_KEEP) + "/")
    text = text.replace("package://meshes/", root + "/meshes/")
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    cache = os.path.join(tempfile.gettempdir(), f"code_as_monitor-{os.getuid()}")
    path = os.path.join(cache, f"panda_{visual}_{digest}.urdf")
    if not os.path.exists(path):
        os.makedirs(cache, exist_ok=True)
        tmp = f"{path}.{os.getpid()}.tmp"
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)  # atomic: concurrent workers write the same bytes
    _URDF_PATHS[(visual, tempfile.gettempdir())] = path
    return path


_URDF_PATHS: dict[tuple[str, str], str] = {}
"""(visual, temporary directory) -> the variant URDF this process wrote or found (hashing the 9 MB of source
meshes again for every world would cost about 8 ms per world)."""


class Panda:
    """A fixed-base Panda at ``base`` (world metres) carrying one end-effector."""

    def __init__(self, client: int, ee_kind: str = "suction", base: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 visual: str = DEFAULT_ROBOT_VISUAL):
        import pybullet as pb

        self.client = c = client
        self.body = pb.loadURDF(panda_urdf(visual), base, useFixedBase=True, physicsClientId=c)
        n = pb.getNumJoints(self.body, physicsClientId=c)
        self.link_names = {-1: "panda_link0"}
        for j in range(n):
            self.link_names[j] = pb.getJointInfo(self.body, j, physicsClientId=c)[12].decode()
        for j, q in enumerate(HOME_Q):
            pb.resetJointState(self.body, j, q, physicsClientId=c)
        for j in FINGER_JOINTS:
            pb.resetJointState(self.body, j, 0.0, physicsClientId=c)
            pb.setCollisionFilterGroupMask(self.body, j, 0, 0, physicsClientId=c)
        info = [pb.getJointInfo(self.body, j, physicsClientId=c) for j in range(n)]
        movable = [j for j in range(n) if info[j][2] != pb.JOINT_FIXED]
        self._ll = [info[j][8] for j in movable]
        self._ul = [info[j][9] for j in movable]
        self._jr = [u - lo for lo, u in zip(self._ll, self._ul)]
        self._rest = [*HOME_Q, 0.0, 0.0]
        self.q_target = list(HOME_Q)
        pb.setJointMotorControlArray(self.body, list(FINGER_JOINTS), pb.POSITION_CONTROL, targetPositions=[0, 0],
                                     forces=[20, 20], physicsClientId=c)
        self.command(self.q_target)
        self.ee: EndEffector = make_end_effector(ee_kind, c)
        self.ee.load(self.body, GRASP_LINK)

    # --- kinematics -----------------------------------------------------------------------------
    def grasp_pose(self) -> np.ndarray:
        """(4, 4) world pose of the grasp frame (forward kinematics)."""
        import pybullet as pb

        st = pb.getLinkState(self.body, GRASP_LINK, computeForwardKinematics=True, physicsClientId=self.client)
        return pose_matrix(st[4], st[5])

    def ee_pose(self) -> np.ndarray:
        """(4, 4) world pose of the tool tip frame (grasp frame translated to the tip)."""
        T = self.grasp_pose()
        T[:3, 3] = T[:3, 3] + T[:3, 2] * self.ee.tip_length
        return T

    def tip(self) -> np.ndarray:
        """(3,) world position of the tool tip, metres."""
        return self.ee_pose()[:3, 3]

    def yaw(self) -> float:
        """Current tool yaw about world z (radians), from the grasp frame's x axis."""
        R = self.grasp_pose()[:3, :3]
        return float(np.arctan2(R[1, 0], R[0, 0]))

    def pitch(self) -> float:
        """Current tool pitch about its own x axis (radians; 0 = pointing down)."""
        R = self.grasp_pose()[:3, :3]
        return float(np.arctan2(-R[2, 1], -R[2, 2]))

    def joints(self) -> np.ndarray:
        import pybullet as pb

        return np.array([s[0] for s in pb.getJointStates(self.body, ARM_JOINTS, physicsClientId=self.client)])

    def _grasp_target(self, tip: np.ndarray, yaw: float, pitch: float) -> tuple[np.ndarray, tuple[float, ...]]:
        """(grasp-frame position (3,) world metres, its orientation quaternion) that puts the tool tip at ``tip``."""
        import pybullet as pb

        orn = down_quat(yaw, pitch)
        R = np.reshape(pb.getMatrixFromQuaternion(orn), (3, 3))
        return np.asarray(tip, float) - R[:, 2] * self.ee.tip_length, orn

    def ik(self, tip: np.ndarray, yaw: float, pitch: float = 0.0) -> list[float]:
        """Arm joint angles (7,) placing the tool tip at ``tip`` with ``yaw`` (and ``pitch``, see module doc)."""
        import pybullet as pb

        grasp, orn = self._grasp_target(tip, yaw, pitch)
        iters = 60
        if pitch:  # a tilted tool is far from the rest posture: converge harder
            iters = 200
        q = pb.calculateInverseKinematics(
            self.body, GRASP_LINK, grasp.tolist(), orn, lowerLimits=self._ll, upperLimits=self._ul,
            jointRanges=self._jr, restPoses=self._rest, maxNumIterations=iters, residualThreshold=1e-5,
            physicsClientId=self.client,
        )
        return list(q[:7])

    def wrist_room(self, tip: np.ndarray, yaw: float, pitch: float = 0.0) -> float:
        """Radians between the last wrist joint (joint 7) and its nearer limit, negative when past it, in an
        inverse-kinematics solution for the tool tip at ``tip`` (3,) world metres with ``yaw`` (and ``pitch``),
        solved from the current joints *without* the limits: how far the wrist would have to turn. With the
        limits the solver stops the joint at its limit and gives up the tip's position instead (centimetres)."""
        import pybullet as pb

        grasp, orn = self._grasp_target(tip, yaw, pitch)
        q = pb.calculateInverseKinematics(self.body, GRASP_LINK, grasp.tolist(), orn, maxNumIterations=60,
                                          residualThreshold=1e-5, physicsClientId=self.client)
        q7 = float(q[6])
        return min(q7 - self._ll[6], self._ul[6] - q7)

    # --- control ----------------------------------------------------------------------------------
    def command(self, q: list[float]) -> None:
        """Set the arm's joint position targets (7,) radians; the motors track them while physics steps."""
        import pybullet as pb

        self.q_target = list(q)
        pb.setJointMotorControlArray(self.body, ARM_JOINTS, pb.POSITION_CONTROL, targetPositions=self.q_target,
                                     forces=ARM_FORCES, positionGains=[0.3] * 7, physicsClientId=self.client)

    def move_tip(self, tip: np.ndarray, yaw: float, pitch: float = 0.0) -> None:
        """Command the tool tip to ``tip`` (3,) world metres with ``yaw`` (and ``pitch``) radians."""
        self.command(self.ik(tip, yaw, pitch))

    def hold(self) -> None:
        """Keep the current joint targets (the arm holds its pose)."""
        self.command(self.q_target)
