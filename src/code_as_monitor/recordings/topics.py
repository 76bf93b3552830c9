"""Which topics of a bag hold what: a :class:`TopicMap` (from YAML, from a recording's metadata, or
the RealSense ROS 2 driver's default names).

YAML layout (every key optional except ``views``)::

    world_frame: base_link          # TF frame the monitor works in (z up, metres)
    views:
      front:
        color: /camera/camera/color/image_raw
        depth: /camera/camera/aligned_depth_to_color/image_raw   # registered to the colour image
        camera_info: /camera/camera/color/camera_info
        frame: camera_color_optical_frame   # default: the colour image's header frame_id
    ee_frame: tool0                 # end-effector TF frame (or ee_topic: a geometry_msgs/PoseStamped)
    ee_kind: gripper                # suction | spatula | gripper
    gripper_joint: finger_joint     # JointState entry whose position is the gripper (0 open .. 1 closed)
    objects: [red_block, green_block, blue_block]   # scene object names the planner grounds in
    sync_tolerance_s: 0.02          # colour/depth/other views matched by header stamp within this
    depth_scale_16uc1: 0.001        # metres per unit of 16UC1 depth
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from code_as_monitor.core.errors import ConfigError

DEFAULT_TOLERANCE_S = 0.02

# Side topics a `cam record` bag carries (std_msgs/String, JSON payloads).
METADATA_TOPIC = "/cam/metadata"
POLICY_TOPIC = "/cam/policy_state"
GROUND_TRUTH_TOPIC = "/cam/ground_truth"


@dataclass
class ViewTopics:
    """One camera's topics. ``seg``: an optional 32SC1 segmentation-id image (simulator ground truth);
    ``frame``: its optical frame in TF (None: the colour image's header ``frame_id``)."""

    color: str
    depth: str
    camera_info: str
    seg: str | None = None
    frame: str | None = None


@dataclass
class TopicMap:
    """Topic names and frames of a bag (see the module docstring for the YAML form)."""

    views: dict[str, ViewTopics]
    world_frame: str = "world"
    tf: str = "/tf"
    tf_static: str = "/tf_static"
    ee_frame: str | None = None
    ee_topic: str | None = None
    ee_points: dict[str, str] = field(default_factory=dict)  # ee point name -> TF frame
    ee_kind: str = "gripper"
    joint_states: str | None = "/joint_states"
    gripper_joint: str | None = None
    policy: str | None = POLICY_TOPIC
    ground_truth: str | None = GROUND_TRUTH_TOPIC
    objects: list[str] = field(default_factory=list)
    object_frames: dict[str, str] = field(default_factory=dict)  # object name -> TF frame (ground truth)
    sync_tolerance_s: float = DEFAULT_TOLERANCE_S
    depth_scale_16uc1: float = 0.001  # metres per unit of a 16UC1 depth image (RealSense: 1 mm)

    def __post_init__(self) -> None:
        if not self.views:
            raise ConfigError("topic map: 'views' must name at least one camera")
        if not self.sync_tolerance_s > 0:
            raise ConfigError(f"topic map: sync_tolerance_s must be > 0, got {self.sync_tolerance_s!r}")
        if not self.depth_scale_16uc1 > 0:
            raise ConfigError(f"topic map: depth_scale_16uc1 must be > 0, got {self.depth_scale_16uc1!r}")
        if self.ee_kind not in ("suction", "spatula", "gripper"):
            raise ConfigError(f"topic map: ee_kind must be suction, spatula or gripper, got {self.ee_kind!r}")

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "topic map") -> TopicMap:
        if not isinstance(d, dict):
            raise ConfigError(f"{where}: expected a mapping at the top level, got {type(d).__name__}")
        known = set(cls.__dataclass_fields__)
        unknown = sorted(set(d) - known)
        if unknown:
            raise ConfigError(f"{where}: unknown key {unknown[0]!r}; known: {', '.join(sorted(known))}")
        views_raw = d.get("views")
        if not isinstance(views_raw, dict) or not views_raw:
            raise ConfigError(f"{where}: 'views' must map view names to their topics")
        views = {}
        for name, v in views_raw.items():
            if not isinstance(v, dict):
                raise ConfigError(f"{where}: view {name!r} must be a mapping of color/depth/camera_info topics")
            missing = [k for k in ("color", "depth", "camera_info") if not v.get(k)]
            if missing:
                raise ConfigError(f"{where}: view {name!r} has no {missing[0]!r} topic")
            extra = sorted(set(v) - set(ViewTopics.__dataclass_fields__))
            if extra:
                raise ConfigError(f"{where}: view {name!r}: unknown key {extra[0]!r}")
            views[str(name)] = ViewTopics(**{k: (str(x) if x is not None else None) for k, x in v.items()})
        rest = {k: v for k, v in d.items() if k != "views"}
        try:
            return cls(views=views, **rest)
        except TypeError as exc:
            raise ConfigError(f"{where}: {exc}") from None

    @classmethod
    def load(cls, path: str | Path) -> TopicMap:
        """Read a YAML (or JSON) topic map; ConfigError naming the file and the problem."""
        from ruamel.yaml import YAML, YAMLError

        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"cannot read topic map {p}: {exc.strerror or exc}") from None
        try:
            data = YAML(typ="safe").load(text)
        except YAMLError as exc:
            raise ConfigError(f"topic map {p} is not valid YAML: {str(exc).splitlines()[0]}") from None
        return cls.from_dict(data, where=f"topic map {p}")

    def to_dict(self) -> dict[str, Any]:
        from dataclasses import asdict

        return asdict(self)


def realsense_default(namespace: str = "/camera/camera") -> TopicMap:
    """The RealSense ROS 2 driver's default names (realsense2_camera 4.5x: namespace ``camera``, name
    ``camera``; older wrappers publish under ``/camera``: pass ``namespace="/camera"`` or a map).
    Aligned depth (``align_depth.enable:=true``) is 16UC1 millimetres in the colour camera's frame.
    Without a robot's TF the monitor's world frame is the camera's ``camera_link``."""
    ns = namespace.rstrip("/")
    view = ViewTopics(color=f"{ns}/color/image_raw", depth=f"{ns}/aligned_depth_to_color/image_raw",
                      camera_info=f"{ns}/color/camera_info")
    return TopicMap(views={"camera": view}, world_frame="camera_link", policy=None, ground_truth=None)


__all__ = ["GROUND_TRUTH_TOPIC", "METADATA_TOPIC", "POLICY_TOPIC", "TopicMap", "ViewTopics", "realsense_default"]
