"""The simulated tabletop world: one PyBullet DIRECT client, a Panda with a tool, named objects.

Clock: physics steps at ``physics_hz`` (240 Hz); the controller ticks at ``control_hz`` (each
:meth:`World.tick` runs ``physics_hz // control_hz`` physics steps); ``World.t`` is sim time in
seconds (ticks x control period). Frames are rendered only when :meth:`World.observe` is called; with
``WorldConfig.defer_render`` only the views whose images are read
(:class:`~code_as_monitor.sim.cameras.DeferredView`). :meth:`World.frame_due` says when the
``camera_hz`` schedule wants one. Same seed, same calls -> same trajectory (everything goes through
this client and ``World.rng``; rendering changes nothing in the physics).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.checks import (
    IMAGE_SIDE_RANGE,
    RATE_HZ_RANGE,
    SIM_CONTROL_HZ,
    check_count,
    check_range,
    check_seed,
)
from code_as_monitor.core.errors import ConfigError, SimError
from code_as_monitor.core.observation import Observation, RobotState, View
from code_as_monitor.sim.backdrop import Backdrop
from code_as_monitor.sim.backdrop import register as register_backdrop
from code_as_monitor.sim.backdrop import unregister as unregister_backdrop
from code_as_monitor.sim.cameras import (
    CameraSpec,
    Images,
    SimCamera,
    default_cameras,
    encode_seg_id,
    load_egl,
)
from code_as_monitor.sim.events import EventLog
from code_as_monitor.sim.robot import DEFAULT_ROBOT_VISUAL, Panda, check_robot_visual, pose_matrix

ASSETS = Path(__file__).parent / "assets"
TABLE_POSITION = (0.3, 0.0, 0.0)
"""The table's base position (m): its 1.6 x 1.6 m top is the plane z = 0."""


@dataclass
class WorldConfig:
    """World settings. ``cameras=None`` means the default front + top views at ``width`` x ``height``."""

    physics_hz: int = 240
    control_hz: int = SIM_CONTROL_HZ
    camera_hz: float = 10.0
    width: int = 320
    height: int = 240
    cameras: list[CameraSpec] | None = None
    renderer: str = "tiny"  # "tiny" (CPU, always available) or "egl" (falls back to tiny if it fails)
    robot_visual: str = DEFAULT_ROBOT_VISUAL  # what cameras see of the arm: decimated, mesh or hull (see panda_urdf)
    defer_render: bool = False  # observe() returns views rendered when first read (see World.observe)
    backdrop: bool = True  # TinyRenderer: the table rendered once per camera pose and composed (sim.backdrop)

    def __post_init__(self) -> None:
        check_count("WorldConfig", "physics_hz", self.physics_hz, 1)
        check_count("WorldConfig", "control_hz", self.control_hz, 1)
        if self.physics_hz % self.control_hz:
            raise ConfigError(f"WorldConfig: physics_hz ({self.physics_hz}) must be a positive multiple of "
                              f"control_hz ({self.control_hz})")
        # at most one frame per control tick: a faster camera would be a slower video that claims its rate
        check_range("WorldConfig", "camera_hz", self.camera_hz, RATE_HZ_RANGE[0], self.control_hz)
        for side in ("width", "height"):
            check_range("WorldConfig", side, getattr(self, side), *IMAGE_SIDE_RANGE, integer=True)
        if self.renderer not in ("tiny", "egl"):
            raise ConfigError(f"WorldConfig.renderer must be 'tiny' or 'egl', got {self.renderer!r}")
        check_robot_visual("WorldConfig", self.robot_visual)


@dataclass
class SimObject:
    """A named scene object. ``parts`` maps a part name to (body id, link index); ``bodies`` lists
    every body the object owns (the rope has one per bead); ``pose_body`` gives ``object_poses[name]``
    (None: the centroid of ``bodies`` with identity rotation)."""

    name: str
    bodies: list[int]
    parts: dict[str, tuple[int, int]] = field(default_factory=dict)
    pose_body: int | None = None
    whole: list[tuple[int, int]] = field(default_factory=list)  # (body, link) labelled with part ""


class World:
    """One simulated tabletop episode's world."""

    def __init__(self, config: WorldConfig | None = None, seed: int = 0, ee: str = "suction") -> None:
        import pybullet as pb

        self.config = cfg = config or WorldConfig()
        self.seed = check_seed("World", seed)
        self.rng = np.random.default_rng(self.seed)
        self.client = c = pb.connect(pb.DIRECT)
        pb.resetSimulation(physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setPhysicsEngineParameter(fixedTimeStep=1.0 / cfg.physics_hz, numSolverIterations=20,
                                     deterministicOverlappingPairs=1, physicsClientId=c)
        self.substeps = cfg.physics_hz // cfg.control_hz
        self.dt = 1.0 / cfg.control_hz
        self.ticks = 0
        self.events = EventLog()
        self.tick_hooks: list[Callable[[World], None]] = []
        self.halted_at: float | None = None  # set by a policy's halt(), cleared by start()
        self.disturbances_paused = False  # counterfactual rollouts: no disturbance starts while True
        self.objects: dict[str, SimObject] = {}
        self.graspable: list[int] = []
        self._body_name: dict[int, str] = {}
        self._seg_labels: dict[int, tuple[str, str]] | None = None
        self._next_frame_tick = 0
        self._deferred: list[Any] = []  # the last deferred views (rendered before a save_state)
        self._frame_key: tuple[int, bytes] | None = None  # the instant of the renders in _frames
        self._frames: dict[tuple[str, tuple[float, ...]], Images] = {}
        self.renderer = cfg.renderer  # the plugin must load before any body so it sees every visual
        if cfg.renderer == "egl" and not load_egl(c):
            self.renderer = "tiny"
        table = pb.loadURDF(str(ASSETS / "table.urdf"), TABLE_POSITION, useFixedBase=True, physicsClientId=c)
        pb.changeDynamics(table, -1, lateralFriction=0.6, restitution=0.0, physicsClientId=c)
        self.add_object("table", [table], whole=[(table, -1)])
        self.backdrop: Backdrop | None = None
        if self.renderer == "tiny" and cfg.backdrop:  # the client's renders skip the table; the backdrop has it
            self.backdrop = Backdrop(ASSETS / "table.urdf", TABLE_POSITION, encode_seg_id(table, -1))
            register_backdrop(c, self.backdrop)
            rgba = pb.getVisualShapeData(table, physicsClientId=c)[0][7]
            pb.changeVisualShape(table, -1, rgbaColor=[*rgba[:3], 0.0], physicsClientId=c)
        self.robot = Panda(c, ee_kind=ee, visual=cfg.robot_visual)
        specs = cfg.cameras if cfg.cameras is not None else default_cameras(cfg.width, cfg.height)
        self.cameras = [SimCamera(s, c, self.renderer, self.robot.grasp_pose if s.mount == "wrist" else None,
                                  self.backdrop) for s in specs]

    # --- objects ------------------------------------------------------------------------------------
    def add_object(self, name: str, bodies: list[int], parts: dict[str, tuple[int, int]] | None = None,
                   whole: list[tuple[int, int]] | None = None, pose_body: int | None = -2,
                   graspable: bool = False) -> SimObject:
        """Register a named object. ``pose_body=-2`` means "the first body".

        ``whole`` lists the (body, link) pairs labelled as the whole object (part ""); by default every
        body's base link that is not a named part, so a plain one-body object is segmented too.
        """
        parts = dict(parts or {})
        if whole is None:
            named = set(parts.values())
            whole = [(b, -1) for b in bodies if (b, -1) not in named]
        obj = SimObject(name, list(bodies), parts, bodies[0] if pose_body == -2 else pose_body, list(whole))
        self.objects[name] = obj
        for b in bodies:
            self._body_name[b] = name
            if graspable:
                self.graspable.append(b)
        self._seg_labels = None
        return obj

    def name_of(self, body: int | None) -> str:
        """Object name owning ``body`` ("" for None or an unknown body)."""
        return "" if body is None else self._body_name.get(body, "")

    def body_of(self, name: str) -> int:
        """Main body id of object ``name``; SimError naming it when unknown."""
        obj = self.objects.get(name)
        if obj is None:
            raise SimError(f"unknown object {name!r}; known: {', '.join(sorted(self.objects))}")
        return obj.bodies[0] if obj.pose_body is None else obj.pose_body

    def pose(self, name: str) -> np.ndarray:
        """(4, 4) ground-truth world pose of object ``name`` or part ``"obj/part"``."""
        import pybullet as pb

        c = self.client
        if "/" in name:
            oname, part = name.split("/", 1)
            obj = self.objects.get(oname)
            if obj is None or part not in obj.parts:
                raise SimError(f"unknown object part {name!r}")
            b, link = obj.parts[part]
            if link < 0:
                return pose_matrix(*pb.getBasePositionAndOrientation(b, physicsClientId=c))
            st = pb.getLinkState(b, link, computeForwardKinematics=True, physicsClientId=c)
            return pose_matrix(st[4], st[5])
        obj = self.objects.get(name)
        if obj is None:
            raise SimError(f"unknown object {name!r}; known: {', '.join(sorted(self.objects))}")
        if obj.pose_body is None:
            T = np.eye(4)
            T[:3, 3] = np.mean([pb.getBasePositionAndOrientation(b, physicsClientId=c)[0] for b in obj.bodies], 0)
            return T
        return pose_matrix(*pb.getBasePositionAndOrientation(obj.pose_body, physicsClientId=c))

    def position(self, name: str) -> np.ndarray:
        """(3,) world position of object or part ``name``, metres."""
        return self.pose(name)[:3, 3].copy()

    def object_poses(self) -> dict[str, np.ndarray]:
        """Ground-truth (4, 4) poses of every object and every named part ("obj/part")."""
        out: dict[str, np.ndarray] = {}
        for name, obj in self.objects.items():
            out[name] = self.pose(name)
            for part in obj.parts:
                out[f"{name}/{part}"] = self.pose(f"{name}/{part}")
        return out

    def seg_labels(self) -> dict[int, tuple[str, str]]:
        """Seg id -> (object, part) for every object link and the robot (``("robot", link name)``)."""
        if self._seg_labels is None:
            lab: dict[int, tuple[str, str]] = {}
            for name, obj in self.objects.items():
                for b, link in obj.whole:
                    lab[encode_seg_id(b, link)] = (name, "")
                for part, (b, link) in obj.parts.items():
                    lab[encode_seg_id(b, link)] = (name, part)
            for link, lname in self.robot.link_names.items():
                lab[encode_seg_id(self.robot.body, link)] = ("robot", lname)
            import pybullet as pb

            ee = self.robot.ee.body
            for link in range(-1, pb.getNumJoints(ee, physicsClientId=self.client)):  # gripper fingers too
                lab[encode_seg_id(ee, link)] = ("robot", self.robot.ee.kind)
            self._seg_labels = lab
        return self._seg_labels

    # --- time -----------------------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Sim time, seconds."""
        return self.ticks * self.dt

    def tick(self) -> None:
        """Advance one control tick: ``substeps`` physics steps, then the tick hooks (disturbances,
        consequence detectors) in registration order."""
        import pybullet as pb

        for _ in range(self.substeps):
            pb.stepSimulation(physicsClientId=self.client)
        self.ticks += 1
        for hook in list(self.tick_hooks):
            hook(self)

    def idle(self, seconds: float) -> None:
        """Hold the arm and advance ``seconds`` of sim time."""
        self.robot.hold()
        for _ in range(round(seconds / self.dt)):
            self.tick()

    def frame_due(self) -> bool:
        """True when the camera schedule (``camera_hz``) wants a frame at the current tick."""
        return self.ticks >= self._next_frame_tick

    # --- observation --------------------------------------------------------------------------------------
    def robot_state(self) -> RobotState:
        T = self.robot.ee_pose()
        points = {"tip": T[:3, 3].copy()}
        fingers = getattr(self.robot.ee, "finger_points", None)
        if fingers is not None:  # the gripper's jaws (their distance is the jaw opening)
            points.update(fingers())
        return RobotState(ee_pose=T, gripper=self.robot.ee.gripper_value(), ee_kind=self.robot.ee.kind,
                          ee_points=points, joints=self.robot.joints())

    def render(self, eager: bool = True) -> dict[str, View]:
        """Every camera's view of the current instant: rendered now (``eager``), or as
        :class:`~code_as_monitor.sim.cameras.DeferredView` s rendered when their images are first read.

        A view of an instant already rendered (the same tick, every body and robot joint where it was)
        reuses that render (a copy of its images): the monitor's last frame of a subgoal and the
        planner's and painter's first frame of the next are one instant, rendered once.
        """
        labels = self.seg_labels()
        if eager:
            views: dict[str, View] = {}
            for cam in self.cameras:
                cam.follow_mount()  # a wrist camera's extrinsics from the arm's state now
                rgb, depth, seg = self._fetch(cam, cam._view)
                views[cam.spec.name] = View(rgb=rgb, depth=depth, camera=cam.camera, seg=seg, seg_labels=dict(labels))
            return views
        views = {cam.spec.name: cam.defer(labels, self._clock, partial(self._fetch, cam)) for cam in self.cameras}
        self._deferred = list(views.values())
        return views

    def _clock(self) -> int:
        return self.ticks if self.client >= 0 else -1

    def _instant_key(self) -> tuple[int, bytes]:
        """The tick and every body's base pose and every joint position, as bytes: equal keys, equal images."""
        import pybullet as pb

        c = self.client
        state: list[float] = []
        for i in range(pb.getNumBodies(physicsClientId=c)):
            b = pb.getBodyUniqueId(i, physicsClientId=c)
            pos, orn = pb.getBasePositionAndOrientation(b, physicsClientId=c)
            state += [*pos, *orn]
            n = pb.getNumJoints(b, physicsClientId=c)
            if n:
                state += [s[0] for s in pb.getJointStates(b, range(n), physicsClientId=c)]
        return self.ticks, np.asarray(state, dtype=np.float64).tobytes()

    def _fetch(self, cam: SimCamera, view_matrix: list[float]) -> Images:
        """Images of ``cam`` from ``view_matrix`` now: rendered, or a copy of the render of this instant
        (keeps the renders of the latest instant only; a deferred view reads at its own tick)."""
        key = self._instant_key()
        if self._frame_key != key:
            self._frame_key, self._frames = key, {}
        hit = self._frames.get((cam.spec.name, tuple(view_matrix)))
        if hit is None:
            hit = self._frames[(cam.spec.name, tuple(view_matrix))] = cam.images(view_matrix)
        return hit[0].copy(), hit[1].copy(), hit[2].copy()

    @property
    def frames_rendered(self) -> int:
        """Camera images rendered so far (one per view and frame actually rendered)."""
        return sum(cam.frames for cam in self.cameras)

    def observe(self, render: bool = True, eager: bool | None = None) -> Observation:
        """The current Observation; advances the frame schedule.

        ``render``: include the views (False: ``views`` is empty). ``eager`` (default: not
        ``WorldConfig.defer_render``): render every view now; otherwise a view is rendered only when
        something reads its images (a consumer that uses only the cameras or the ground-truth poses
        costs no render), and the read must come before the world ticks again (a later read raises
        SimError): for loops that consume each frame as it comes, as the benchmark's do.
        """
        if eager is None:
            eager = not self.config.defer_render
        period = max(1, round(self.config.control_hz / self.config.camera_hz))
        self._next_frame_tick = (self.ticks // period + 1) * period
        objects = [n for n in self.objects if n != "table"] + ["table"]
        return Observation(t=self.t, views=self.render(eager) if render else {}, robot=self.robot_state(),
                           objects=objects, object_poses=self.object_poses())

    def camera_models(self) -> dict[str, Any]:
        """Every camera's model now (a wrist camera's extrinsics from the arm's current state)."""
        for cam in self.cameras:
            cam.follow_mount()
        return {cam.spec.name: cam.camera for cam in self.cameras}

    # --- state ------------------------------------------------------------------------------------------------
    def save_state(self) -> dict[str, Any]:
        """Snapshot for counterfactual rollouts: physics state, clock, event count, suction attachment.
        Views of the current instant not yet rendered are rendered first.

        Restore only into this same world (objects are never added after reset)."""
        import pybullet as pb

        for v in self._deferred:  # a rollout from here moves the world: fix this instant's views first
            if v._tick == self.ticks:
                v.materialize()
        self._deferred = []
        ee = self.robot.ee
        return {"state": pb.saveState(physicsClientId=self.client), "ticks": self.ticks, "n_events": len(self.events),
                "q_target": list(self.robot.q_target), "ee_active": ee.active,
                "held": ee.attachment() if hasattr(ee, "attachment") else None, "halted_at": self.halted_at}

    def restore_state(self, token: dict[str, Any]) -> None:
        """Go back to a :meth:`save_state` snapshot (events logged after it are dropped)."""
        import pybullet as pb

        ee = self.robot.ee
        if hasattr(ee, "detach"):
            ee.detach()
        pb.restoreState(stateId=token["state"], physicsClientId=self.client)
        self.ticks = token["ticks"]
        self.events.truncate(token["n_events"])
        self.robot.command(token["q_target"])
        ee.active = token["ee_active"]
        if token["held"] is not None:
            ee.attach(*token["held"])
        self.halted_at = token["halted_at"]

    def close(self) -> None:
        import pybullet as pb

        if self.client >= 0:
            unregister_backdrop(self.client)
            pb.disconnect(physicsClientId=self.client)
            self.client = -1
        if self.backdrop is not None:
            self.backdrop.close()
        self.events.close()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
