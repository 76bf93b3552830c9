"""Read any RGB-D ROS 2 bag as a stream of observations, synchronised by header stamps.

Two passes over the bag. The first reads every header (images are deserialised without copying),
the small topics (TF, ``/tf_static``, joint states, end-effector poses, the policy state, ground
truth) and the metadata, and matches each frame of the first view's colour stream with the nearest
message of every other image stream (the view's depth, the other views, segmentation) within
``sync_tolerance_s``; a colour frame with no partner in a stream is dropped and counted. The second
pass decodes only the matched images and yields :class:`~code_as_monitor.core.observation.Observation`
objects in stamp order, holding no more frames in memory than are waiting for a partner.

Everything wrong with a bag (unreadable, truncated, a topic missing, an unknown encoding, colour and
depth of different sizes, a frame not connected in TF) is a :class:`RecordingError` naming it; the
constructor checks the first frame completely, so most are found before anything is run.
"""

from __future__ import annotations

import bisect
import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import CamError, RecordingError
from code_as_monitor.core.observation import Observation, RobotState, View
from code_as_monitor.recordings.convert import (
    camera_info_k,
    image_to_depth,
    image_to_rgb,
    image_to_seg,
    stamp_ns,
    transform_to_matrix,
)
from code_as_monitor.recordings.tf import TFBuffer
from code_as_monitor.recordings.topics import METADATA_TOPIC, TopicMap, realsense_default


@dataclass
class _Frame:
    t_ns: int
    parts: dict[str, int]  # stream key -> message index


@dataclass
class SyncStats:
    """How the streams lined up: colour frames found, frames yielded, and frames dropped per stream
    (no message of that stream within the tolerance)."""

    color_frames: int = 0
    frames: int = 0
    dropped: dict[str, int] = field(default_factory=dict)

    @property
    def dropped_total(self) -> int:
        return self.color_frames - self.frames

    def to_dict(self) -> dict[str, Any]:
        return {"color_frames": self.color_frames, "frames": self.frames, "dropped": self.dropped_total,
                "dropped_by_stream": dict(self.dropped)}


def _open(path: Path) -> Any:
    from rosbags.rosbag2 import Reader

    if not path.exists():
        raise RecordingError(f"bag {path} does not exist")
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:
        raise RecordingError(f"cannot read bag {path}: {type(exc).__name__}: {exc}") from None
    return reader


class BagSource:
    """Observations from a bag (see the module docstring).

    Args:
        path: a ``.mcap`` or ``.db3`` file or a rosbag2 directory.
        topics: the topic map; None: the one a ``cam record`` bag carries, else the RealSense default.
        objects: scene object names for the planner (overrides the map's / the metadata's).
    """

    def __init__(self, path: str | Path, topics: TopicMap | None = None, objects: list[str] | None = None) -> None:
        from rosbags.typesys import Stores, get_typestore

        if not isinstance(path, str | Path) or not str(path):
            raise RecordingError(f"a bag path must be a non-empty str or Path, got {path!r}")
        self.path = Path(path)
        self.ts = get_typestore(Stores.ROS2_HUMBLE)
        reader = _open(self.path)
        try:
            self.available = {c.topic: c.msgtype for c in reader.connections}
            self.metadata = self._metadata(reader) if METADATA_TOPIC in self.available else {}
            if topics is None:
                topics = (TopicMap.from_dict(self.metadata["topics"], where=f"{self.path} metadata")
                          if "topics" in self.metadata else realsense_default())
            self.map = topics
            if objects:
                self.map.objects = list(objects)
            self._check_topics()
            self._first_pass(reader)
        except CamError:
            raise
        except Exception as exc:
            raise RecordingError(f"cannot read bag {self.path}: {type(exc).__name__}: {exc}") from None
        finally:
            reader.close()
        self.seg_labels = {v: {int(k): (lab[0], lab[1]) for k, lab in d.items()}
                           for v, d in self.metadata.get("seg_labels", {}).items()}
        if not self._frames:
            raise RecordingError(f"bag {self.path}: no colour frame of view {self._primary!r} has a partner in "
                                 f"every stream within {self.map.sync_tolerance_s} s ({self.stats.to_dict()})")
        self.first = next(iter(self._iterate(limit=1)))  # checks the first frame completely

    # --- first pass -----------------------------------------------------------------------------------
    def _metadata(self, reader: Any) -> dict[str, Any]:
        conns = [c for c in reader.connections if c.topic == METADATA_TOPIC]
        for c, _, raw in reader.messages(connections=conns):
            return json.loads(self.ts.deserialize_cdr(raw, c.msgtype).data)
        return {}

    def _streams(self) -> dict[str, tuple[str, str, str]]:
        """stream key -> (view, kind, topic) for every image stream."""
        out = {}
        for name, v in self.map.views.items():
            out[f"{name}/color"] = (name, "color", v.color)
            out[f"{name}/depth"] = (name, "depth", v.depth)
            if v.seg:
                out[f"{name}/seg"] = (name, "seg", v.seg)
        return out

    def _check_topics(self) -> None:
        need = [t for _, _, t in self._streams().values()] + [v.camera_info for v in self.map.views.values()]
        if self.map.ee_topic:
            need.append(self.map.ee_topic)
        for t in need:
            if t not in self.available:
                raise RecordingError(f"bag {self.path} has no topic {t!r}; its topics: "
                                     f"{', '.join(sorted(self.available))} (pass --topics MAP.yaml to name yours)")
        if self.map.tf_static not in self.available and self.map.tf not in self.available:
            raise RecordingError(f"bag {self.path} has no {self.map.tf_static} or {self.map.tf}: camera extrinsics "
                                 f"are unknown")

    def _first_pass(self, reader: Any) -> None:
        m = self.map
        streams = self._streams()
        by_topic: dict[str, list[str]] = {}
        for key, (_, _, topic) in streams.items():
            by_topic.setdefault(topic, []).append(key)
        info_topics = {v.camera_info: n for n, v in m.views.items()}
        stamps: dict[str, list[tuple[int, int]]] = {k: [] for k in streams}
        self.tf = TFBuffer()
        self._infos: dict[str, list[tuple[int, np.ndarray, int, int, str]]] = {n: [] for n in m.views}
        self._frame_ids: dict[str, str] = {}
        self._joints: list[tuple[int, list[str], np.ndarray]] = []
        self._ee_poses: list[tuple[int, str, np.ndarray]] = []
        self._policy: list[tuple[int, bool]] = []
        self.ground_truth: list[dict[str, Any]] = []
        wanted = set(by_topic) | set(info_topics) | {m.tf, m.tf_static}
        wanted |= {t for t in (m.joint_states, m.ee_topic, m.policy, m.ground_truth) if t}
        conns = [c for c in reader.connections if c.topic in wanted]
        for index, (c, log_ns, raw) in enumerate(reader.messages(connections=conns)):
            topic = c.topic
            if topic in by_topic:  # images: only the header is needed here, read from the CDR bytes
                t_ns, frame_id = _header_of(raw) or _deserialized_header(self.ts, raw, c.msgtype)
                for key in by_topic[topic]:
                    stamps[key].append((t_ns, index))
                    if key.endswith("/color"):
                        self._frame_ids.setdefault(streams[key][0], frame_id)
                continue
            msg = self.ts.deserialize_cdr(raw, c.msgtype)
            if topic in info_topics:
                K, w, h = camera_info_k(msg, topic)
                self._infos[info_topics[topic]].append((stamp_ns(msg.header), K, w, h, str(msg.header.frame_id)))
            elif topic in (m.tf, m.tf_static):
                for tr in msg.transforms:
                    self.tf.add(str(tr.header.frame_id), str(tr.child_frame_id), transform_to_matrix(tr.transform),
                                stamp_ns(tr.header), static=topic == m.tf_static)
            elif topic == m.joint_states:
                self._joints.append((stamp_ns(msg.header), [str(n) for n in msg.name],
                                     np.asarray(msg.position, dtype=np.float64)))
            elif topic == m.ee_topic:
                pose = transform_to_matrix(msg.pose)
                self._ee_poses.append((stamp_ns(msg.header), str(msg.header.frame_id), pose))
            elif topic == m.policy:
                self._policy.append((log_ns, bool(json.loads(msg.data).get("done", False))))
            elif topic == m.ground_truth:
                self.ground_truth.append(json.loads(msg.data))
        for name, infos in self._infos.items():
            if not infos:
                raise RecordingError(f"bag {self.path}: no message on {m.views[name].camera_info}")
            infos.sort(key=lambda x: x[0])
        self._joints.sort(key=lambda x: x[0])
        self._ee_poses.sort(key=lambda x: x[0])
        self._policy.sort(key=lambda x: x[0])
        self._sync(stamps)

    def _sync(self, stamps: dict[str, list[tuple[int, int]]]) -> None:
        self._primary = next(iter(self.map.views))
        pkey = f"{self._primary}/color"
        tol = int(self.map.sync_tolerance_s * 1e9)
        others = {k: sorted(v) for k, v in stamps.items() if k != pkey}
        other_t = {k: [s for s, _ in v] for k, v in others.items()}
        self.stats = SyncStats(dropped={k: 0 for k in others})
        self._frames: list[_Frame] = []
        for s, idx in sorted(stamps[pkey]):
            self.stats.color_frames += 1
            parts = {pkey: idx}
            for k, ts in other_t.items():
                j = bisect.bisect_left(ts, s)
                best = min((c for c in (j - 1, j) if 0 <= c < len(ts)), key=lambda c: abs(ts[c] - s), default=None)
                if best is None or abs(ts[best] - s) > tol:
                    self.stats.dropped[k] += 1
                    break
                parts[k] = others[k][best][1]
            else:
                self._frames.append(_Frame(s, parts))
        self.stats.frames = len(self._frames)
        self.t0_ns = self._frames[0].t_ns if self._frames else 0

    # --- second pass ------------------------------------------------------------------------------------
    @property
    def duration_s(self) -> float:
        return (self._frames[-1].t_ns - self.t0_ns) / 1e9 if self._frames else 0.0

    def __len__(self) -> int:
        return len(self._frames)

    def __iter__(self) -> Iterator[tuple[Observation, bool]]:
        """(observation, policy_done) per synchronised frame, in stamp order."""
        return self._iterate()

    def _iterate(self, limit: int | None = None) -> Iterator[tuple[Observation, bool]]:
        frames = self._frames[:limit] if limit else self._frames
        need: dict[int, int] = {}
        for f in frames:
            for i in f.parts.values():
                need[i] = need.get(i, 0) + 1
        topics = {t for _, _, t in self._streams().values()}
        reader = _open(self.path)
        decoded: dict[int, Any] = {}
        nxt = 0
        try:
            conns = [c for c in reader.connections if c.topic in topics]
            for index, (c, _, raw) in enumerate(self._indexed(reader, conns)):
                if index not in need:
                    continue
                decoded[index] = self.ts.deserialize_cdr(raw, c.msgtype)
                while nxt < len(frames) and all(i in decoded for i in frames[nxt].parts.values()):
                    f = frames[nxt]
                    yield self._assemble(f, decoded), self._policy_done(f.t_ns)
                    for i in f.parts.values():
                        need[i] -= 1
                        if need[i] == 0:
                            decoded.pop(i, None)
                    nxt += 1
                if nxt >= len(frames):
                    return
        except CamError:
            raise
        except Exception as exc:
            raise RecordingError(f"cannot read bag {self.path}: {type(exc).__name__}: {exc}") from None
        finally:
            reader.close()

    def _indexed(self, reader: Any, image_conns: list[Any]) -> Iterator[tuple[Any, int, bytes]]:
        """The first pass's message sequence (same connections, same order), so indices agree; only
        image messages are yielded with their index, the others as ``(None, 0, b"")`` placeholders."""
        m = self.map
        small = {v.camera_info for v in m.views.values()} | {m.tf, m.tf_static}
        small |= {t for t in (m.joint_states, m.ee_topic, m.policy, m.ground_truth) if t}
        img = {c.topic for c in image_conns}
        conns = [c for c in reader.connections if c.topic in img or c.topic in small]
        for c, t, raw in reader.messages(connections=conns):
            yield (c, t, raw) if c.topic in img else (_Skip, 0, b"")

    def _nearest_info(self, view: str, t_ns: int) -> tuple[np.ndarray, int, int, str]:
        infos = self._infos[view]
        i = max(0, bisect.bisect_right([x[0] for x in infos], t_ns) - 1)
        return infos[i][1:]

    def _assemble(self, f: _Frame, decoded: dict[int, Any]) -> Observation:
        m = self.map
        views = {}
        for name, vt in m.views.items():
            K, w, h, info_frame = self._nearest_info(name, f.t_ns)
            rgb = image_to_rgb(decoded[f.parts[f"{name}/color"]], vt.color)
            depth = image_to_depth(decoded[f.parts[f"{name}/depth"]], vt.depth, m.depth_scale_16uc1)
            if depth.shape != rgb.shape[:2]:
                raise RecordingError(f"view {name!r}: depth {depth.shape[1]}x{depth.shape[0]} ({vt.depth}) does not "
                                     f"match colour {rgb.shape[1]}x{rgb.shape[0]} ({vt.color}); the monitor needs "
                                     f"depth registered to the colour image (RealSense: align_depth.enable)")
            if (h, w) != rgb.shape[:2]:
                raise RecordingError(f"view {name!r}: camera_info says {w}x{h}, the colour image is "
                                     f"{rgb.shape[1]}x{rgb.shape[0]}")
            frame = vt.frame or self._frame_ids.get(name) or info_frame
            cam = CameraModel(name, w, h, K, self.tf.lookup(m.world_frame, frame, f.t_ns))
            seg = None
            if vt.seg:
                seg = image_to_seg(decoded[f.parts[f"{name}/seg"]], vt.seg)
            labels = self.seg_labels.get(name) if seg is not None else None
            views[name] = View(rgb, depth, cam, seg=seg, seg_labels=labels)
        poses = {n: self.tf.lookup(m.world_frame, fr, f.t_ns) for n, fr in m.object_frames.items()} or None
        return Observation(t=(f.t_ns - self.t0_ns) / 1e9, views=views, robot=self._robot(f.t_ns),
                           objects=list(m.objects or self.metadata.get("objects", [])), object_poses=poses)

    def _robot(self, t_ns: int) -> RobotState | None:
        m = self.map
        if m.ee_frame:
            ee = self.tf.lookup(m.world_frame, m.ee_frame, t_ns)
        elif m.ee_topic and self._ee_poses:
            i = max(0, bisect.bisect_right([x[0] for x in self._ee_poses], t_ns) - 1)
            _, frame, pose = self._ee_poses[i]
            ee = self.tf.lookup(m.world_frame, frame, t_ns) @ pose if frame else pose
        else:
            return None
        points = {k: self.tf.lookup(m.world_frame, fr, t_ns)[:3, 3] for k, fr in m.ee_points.items()}
        points.setdefault("tip", ee[:3, 3].copy())
        gripper, joints = 0.0, None
        if self._joints:
            i = max(0, bisect.bisect_right([x[0] for x in self._joints], t_ns) - 1)
            _, names, pos = self._joints[i]
            keep = [j for j, n in enumerate(names) if n != m.gripper_joint]
            joints = pos[keep]
            if m.gripper_joint in names:
                gripper = float(pos[names.index(m.gripper_joint)])
        return RobotState(ee_pose=ee, gripper=gripper, ee_kind=m.ee_kind, ee_points=points, joints=joints)

    def _policy_done(self, t_ns: int) -> bool:
        if not self._policy:
            return False
        i = bisect.bisect_right([x[0] for x in self._policy], t_ns) - 1
        return self._policy[i][1] if i >= 0 else False


def _header_of(raw: bytes | memoryview) -> tuple[int, str] | None:
    """(stamp ns, frame_id) of a message whose first field is a ``std_msgs/Header``, read straight from
    little-endian CDR (encapsulation 0x0001); None for anything else (the caller deserialises)."""
    b = bytes(raw[:4096])
    if len(b) < 16 or b[0:2] != b"\x00\x01":
        return None
    sec, nsec, n = struct.unpack_from("<iII", b, 4)
    if n == 0 or 16 + n > len(b) or nsec >= 1_000_000_000:
        return None
    return sec * 1_000_000_000 + nsec, b[16:16 + n - 1].decode("utf-8", "replace")


def _deserialized_header(ts: Any, raw: Any, msgtype: str) -> tuple[int, str]:
    msg = ts.deserialize_cdr(raw, msgtype)
    return stamp_ns(msg.header), str(msg.header.frame_id)


class _Skip:
    """Placeholder connection for a non-image message in the second pass."""

    topic = ""
    msgtype = ""


__all__ = ["BagSource", "SyncStats"]
