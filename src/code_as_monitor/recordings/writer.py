"""Write observations as a ROS 2 bag (MCAP or sqlite3) with standard messages, via ``rosbags``.

Per frame and view: ``/cam/<view>/color/image_raw`` (rgb8), ``/cam/<view>/depth/image_raw`` (32FC1
metres, or 16UC1 millimetres), ``/cam/<view>/color/camera_info``, optionally the ground-truth
segmentation ``/cam/<view>/seg/image_raw`` (32SC1 ids; labels in the metadata). Per frame: ``/tf``
with ``world -> ee`` (the end-effector pose), ``world -> ee/<point>`` (forward-kinematics points) and,
for a simulator recording, ``world -> gt/<object>`` (ground-truth poses); ``/joint_states`` (arm
joints and ``gripper``); ``/cam/policy_state`` (``{"done": bool}``). Once: ``/tf_static`` with
``world -> <view>_optical_frame`` and ``/cam/metadata``. Ground-truth events go to
``/cam/ground_truth`` as they happen. All messages share the frame's stamp as header and log time.

The bag is written under a temporary name beside the output and moved into place only by
:meth:`BagWriter.close` after a complete write: an interrupted recording leaves nothing that looks
complete.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.errors import RecordingError
from code_as_monitor.core.observation import Observation
from code_as_monitor.recordings.convert import matrix_to_quat_xyz
from code_as_monitor.recordings.topics import GROUND_TRUTH_TOPIC, METADATA_TOPIC, POLICY_TOPIC, TopicMap, ViewTopics

FORMAT = "cam-recording/1"
WORLD = "world"


def view_topics(name: str, with_seg: bool) -> ViewTopics:
    return ViewTopics(color=f"/cam/{name}/color/image_raw", depth=f"/cam/{name}/depth/image_raw",
                      camera_info=f"/cam/{name}/color/camera_info",
                      seg=f"/cam/{name}/seg/image_raw" if with_seg else None, frame=f"{name}_optical_frame")


class BagWriter:
    """Records observations into ``path`` (``.mcap``: one MCAP file; ``.db3``: one sqlite3 file;
    anything else: a rosbag2 directory with MCAP storage).

    Args:
        depth_encoding: ``32FC1`` (metres, exact) or ``16UC1`` (millimetres, as RealSense drivers).
        with_seg: write the views' segmentation images when they have them.
        metadata: JSON-serialisable facts stored on ``/cam/metadata`` (task, seed, instruction, ...).
    """

    def __init__(self, path: str | os.PathLike[str], depth_encoding: str = "32FC1", with_seg: bool = True,
                 metadata: dict[str, Any] | None = None) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        if depth_encoding not in ("32FC1", "16UC1"):
            raise RecordingError(f"depth_encoding must be 32FC1 or 16UC1, got {depth_encoding!r}")
        self.path = Path(path)
        if self.path.exists():
            raise RecordingError(f"{self.path} exists already; refusing to overwrite a recording")
        if not self.path.parent.is_dir():
            raise RecordingError(f"cannot write {self.path}: directory {self.path.parent} does not exist")
        self.depth_encoding = depth_encoding
        self.with_seg = with_seg
        self.metadata = dict(metadata or {})
        self.ts = get_typestore(Stores.ROS2_HUMBLE)
        storage = StoragePlugin.SQLITE3 if self.path.suffix == ".db3" else StoragePlugin.MCAP
        self._tmp = self.path.with_name(f".{self.path.name}.partial-{os.getpid()}")
        shutil.rmtree(self._tmp, ignore_errors=True)
        self._bagdir = self._tmp / "bag" if self.path.suffix in (".mcap", ".db3") else self._tmp
        if self._bagdir != self._tmp:
            self._tmp.mkdir()
        self._w = Writer(self._bagdir, version=9, storage_plugin=storage)
        self._w.open()
        self._conns: dict[str, Any] = {}
        self._started = False
        self._last_ns = -1
        self.frames = 0

    # --- messages -------------------------------------------------------------------------------------
    def _write(self, topic: str, msgtype: str, msg: Any, t_ns: int) -> None:
        conn = self._conns.get(topic)
        if conn is None:
            conn = self._conns[topic] = self._w.add_connection(topic, msgtype, typestore=self.ts)
        self._w.write(conn, t_ns, self.ts.serialize_cdr(msg, msgtype))

    def _header(self, t_ns: int, frame: str) -> Any:
        T = self.ts.types
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000), frame_id=frame)

    def _image(self, arr: np.ndarray, encoding: str, t_ns: int, frame: str) -> Any:
        arr = np.ascontiguousarray(arr)
        h, w = arr.shape[:2]
        return self.ts.types["sensor_msgs/msg/Image"](
            header=self._header(t_ns, frame), height=h, width=w, encoding=encoding, is_bigendian=0,
            step=arr.strides[0], data=arr.reshape(-1).view(np.uint8))

    def _tf(self, t_ns: int, frames: dict[str, np.ndarray]) -> Any:
        T = self.ts.types
        out = []
        for child, M in frames.items():
            q, p = matrix_to_quat_xyz(M)
            out.append(T["geometry_msgs/msg/TransformStamped"](
                header=self._header(t_ns, WORLD), child_frame_id=child,
                transform=T["geometry_msgs/msg/Transform"](
                    translation=T["geometry_msgs/msg/Vector3"](x=float(p[0]), y=float(p[1]), z=float(p[2])),
                    rotation=T["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]), z=float(q[2]),
                                                               w=float(q[3])))))
        return T["tf2_msgs/msg/TFMessage"](transforms=out)

    def _string(self, data: Any) -> Any:
        return self.ts.types["std_msgs/msg/String"](data=json.dumps(data, separators=(",", ":")))

    def _camera_info(self, cam: Any, t_ns: int, frame: str) -> Any:
        T = self.ts.types
        K = np.asarray(cam.K, dtype=np.float64)
        P = np.zeros((3, 4))
        P[:, :3] = K
        return T["sensor_msgs/msg/CameraInfo"](
            header=self._header(t_ns, frame), height=cam.height, width=cam.width, distortion_model="plumb_bob",
            d=np.zeros(5), k=K.reshape(-1), r=np.eye(3).reshape(-1), p=P.reshape(-1), binning_x=0, binning_y=0,
            roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))

    # --- public -----------------------------------------------------------------------------------------
    def topic_map(self, obs: Observation) -> TopicMap:
        """The map a reader needs for what this writer writes (also stored in the metadata)."""
        robot = obs.robot
        return TopicMap(
            views={n: view_topics(n, self.with_seg and v.seg is not None) for n, v in obs.views.items()},
            world_frame=WORLD, ee_frame="ee" if robot is not None else None,
            ee_points={k: f"ee/{k}" for k in (robot.ee_points if robot is not None else {})},
            ee_kind=robot.ee_kind if robot is not None else "gripper", gripper_joint="gripper",
            objects=list(obs.objects),
            object_frames={n: f"gt/{n}" for n in (obs.object_poses or {})},
        )

    def write_observation(self, obs: Observation, policy_done: bool) -> None:
        """Append one frame (all views, robot state, TF, policy state) stamped ``obs.t``."""
        t_ns = round(obs.t * 1e9)
        if t_ns < self._last_ns:
            raise RecordingError(f"observation time went backwards: {obs.t!r}")
        self._last_ns = t_ns
        if not self._started:
            self._start(obs, t_ns)
        for name, v in obs.views.items():
            frame = f"{name}_optical_frame"
            topics = view_topics(name, True)
            self._write(topics.color, "sensor_msgs/msg/Image", self._image(v.rgb, "rgb8", t_ns, frame), t_ns)
            depth = np.nan_to_num(np.asarray(v.depth, np.float32), nan=0.0, posinf=0.0, neginf=0.0)
            if self.depth_encoding == "16UC1":
                depth = np.clip(np.round(depth * 1000.0), 0, 65535).astype(np.uint16)
            self._write(topics.depth, "sensor_msgs/msg/Image", self._image(depth, self.depth_encoding, t_ns, frame),
                        t_ns)
            self._write(topics.camera_info, "sensor_msgs/msg/CameraInfo", self._camera_info(v.camera, t_ns, frame),
                        t_ns)
            if self.with_seg and v.seg is not None and topics.seg:
                self._write(topics.seg, "sensor_msgs/msg/Image",
                            self._image(np.asarray(v.seg, np.int32), "32SC1", t_ns, frame), t_ns)
        frames: dict[str, np.ndarray] = {}
        if obs.robot is not None:
            frames["ee"] = np.asarray(obs.robot.ee_pose, dtype=np.float64)
            for k, p in obs.robot.ee_points.items():
                M = np.eye(4)
                M[:3, 3] = p
                frames[f"ee/{k}"] = M
            joints = np.asarray(obs.robot.joints if obs.robot.joints is not None else [], dtype=np.float64)
            js = self.ts.types["sensor_msgs/msg/JointState"](
                header=self._header(t_ns, ""), name=[f"joint_{i}" for i in range(len(joints))] + ["gripper"],
                position=np.append(joints, float(obs.robot.gripper)), velocity=np.zeros(0), effort=np.zeros(0))
            self._write("/joint_states", "sensor_msgs/msg/JointState", js, t_ns)
        for n, M in (obs.object_poses or {}).items():
            frames[f"gt/{n}"] = np.asarray(M, dtype=np.float64)
        if frames:
            self._write("/tf", "tf2_msgs/msg/TFMessage", self._tf(t_ns, frames), t_ns)
        self._write(POLICY_TOPIC, "std_msgs/msg/String", self._string({"done": bool(policy_done)}), t_ns)
        self.frames += 1

    def write_event(self, event: dict[str, Any]) -> None:
        """A ground-truth event (``{"t": seconds, "kind": ..., ...}``) on ``/cam/ground_truth``."""
        t_ns = max(round(float(event.get("t", 0.0)) * 1e9), 0)
        self._write(GROUND_TRUTH_TOPIC, "std_msgs/msg/String", self._string(event), t_ns)

    def _start(self, obs: Observation, t_ns: int) -> None:
        self._started = True
        static = {f"{n}_optical_frame": np.asarray(v.camera.T_world_cam, dtype=np.float64)
                  for n, v in obs.views.items()}
        self._write("/tf_static", "tf2_msgs/msg/TFMessage", self._tf(t_ns, static), t_ns)
        meta = {"format": FORMAT, **self.metadata, "topics": self.topic_map(obs).to_dict(),
                "depth_encoding": self.depth_encoding,
                "seg_labels": {n: {str(k): list(lab) for k, lab in (v.seg_labels or {}).items()}
                               for n, v in obs.views.items() if self.with_seg and v.seg is not None}}
        self._write(METADATA_TOPIC, "std_msgs/msg/String", self._string(meta), t_ns)

    def close(self, complete: bool = True) -> Path | None:
        """Finish the bag and move it into place (``complete``), or delete the partial write."""
        try:
            self._w.close()
        except Exception:  # a failed close is an incomplete bag
            complete = False
        if not complete or not self._started:
            shutil.rmtree(self._tmp, ignore_errors=True)
            return None
        if self._bagdir != self._tmp:
            (inner,) = [p for p in self._bagdir.iterdir() if p.suffix == self.path.suffix]
            os.replace(inner, self.path)
            shutil.rmtree(self._tmp, ignore_errors=True)
        else:
            os.replace(self._tmp, self.path)
        return self.path


__all__ = ["FORMAT", "BagWriter", "view_topics"]
