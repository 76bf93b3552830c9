"""Conversions between ROS 2 messages (as ``rosbags`` builds them) and the project's arrays.

Frames and units: images are (H, W[, C]) row-major; colour out is RGB ``uint8 (H, W, 3)``; depth out
is ``float32 (H, W)`` metres with 0 = no reading (16UC1 is millimetres, 32FC1 metres with NaN/0
for none). Transforms are 4x4 ``T_parent_child`` (a point in the child frame -> parent frame).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from code_as_monitor.core.errors import RecordingError

COLOR_ENCODINGS = ("rgb8", "bgr8", "rgba8", "bgra8")
DEPTH_ENCODINGS = ("16UC1", "32FC1")
SEG_ENCODING = "32SC1"
_DTYPES = {"rgb8": (np.uint8, 3), "bgr8": (np.uint8, 3), "rgba8": (np.uint8, 4), "bgra8": (np.uint8, 4),
           "16UC1": (np.uint16, 1), "mono16": (np.uint16, 1), "32FC1": (np.float32, 1), "32SC1": (np.int32, 1)}


def stamp_ns(header: Any) -> int:
    """Nanoseconds of a ``std_msgs/Header``'s stamp."""
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _pixels(msg: Any, topic: str) -> np.ndarray:
    """(H, W, C) array over an Image message's data, honouring ``step`` padding and endianness."""
    enc = str(msg.encoding)
    if enc not in _DTYPES:
        raise RecordingError(f"{topic}: unknown image encoding {enc!r}; supported: "
                             f"{', '.join(COLOR_ENCODINGS + DEPTH_ENCODINGS + (SEG_ENCODING,))}")
    dtype, ch = _DTYPES[enc]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    itemsize = np.dtype(dtype).itemsize
    data = np.asarray(msg.data, dtype=np.uint8)
    if h <= 0 or w <= 0 or step < w * ch * itemsize or data.size < h * step:
        raise RecordingError(f"{topic}: image data of {data.size} bytes does not hold {w}x{h} {enc} "
                             f"with step {step}")
    rows = data[: h * step].reshape(h, step)[:, : w * ch * itemsize]
    dt = np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<")
    return np.ascontiguousarray(rows).view(dt).reshape(h, w, ch).astype(dtype, copy=False)


def image_to_rgb(msg: Any, topic: str) -> np.ndarray:
    """RGB ``uint8 (H, W, 3)`` from an rgb8 / bgr8 / rgba8 / bgra8 Image."""
    enc = str(msg.encoding)
    if enc not in COLOR_ENCODINGS:
        raise RecordingError(f"{topic}: colour image encoding {enc!r} is not one of {', '.join(COLOR_ENCODINGS)}")
    px = _pixels(msg, topic)
    px = px[:, :, :3]
    return np.ascontiguousarray(px[:, :, ::-1] if enc.startswith("bgr") else px)


def image_to_depth(msg: Any, topic: str, mm_scale: float = 0.001) -> np.ndarray:
    """Depth ``float32 (H, W)`` metres from a 16UC1 (millimetres x ``mm_scale``) or 32FC1 (metres) Image;
    0 and NaN mean no reading (NaN and inf are mapped to 0)."""
    enc = str(msg.encoding)
    if enc not in DEPTH_ENCODINGS:
        raise RecordingError(f"{topic}: depth image encoding {enc!r} is not one of {', '.join(DEPTH_ENCODINGS)}")
    px = _pixels(msg, topic)[:, :, 0]
    depth = px.astype(np.float32) * np.float32(mm_scale) if enc == "16UC1" else px.astype(np.float32, copy=True)
    depth[~np.isfinite(depth)] = 0.0
    return depth


def image_to_seg(msg: Any, topic: str) -> np.ndarray:
    """Segmentation ids ``int32 (H, W)`` from a 32SC1 Image."""
    if str(msg.encoding) != SEG_ENCODING:
        raise RecordingError(f"{topic}: segmentation encoding {msg.encoding!r} is not {SEG_ENCODING}")
    return np.ascontiguousarray(_pixels(msg, topic)[:, :, 0])


def camera_info_k(msg: Any, topic: str) -> tuple[np.ndarray, int, int]:
    """(K 3x3, width, height) of a CameraInfo; RecordingError on a K that is not a pinhole matrix."""
    K = np.asarray(msg.k, dtype=np.float64).reshape(3, 3)
    if not (K[0, 0] > 0 and K[1, 1] > 0 and K[2, 2] == 1.0):
        raise RecordingError(f"{topic}: camera_info K {K.ravel().tolist()} is not a calibrated pinhole matrix")
    return K, int(msg.width), int(msg.height)


def transform_to_matrix(tr: Any) -> np.ndarray:
    """4x4 from a ``geometry_msgs/Transform`` (or Pose: ``position``/``orientation``)."""
    t = getattr(tr, "translation", None) or tr.position
    q = getattr(tr, "rotation", None) or tr.orientation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    T[:3, 3] = [t.x, t.y, t.z]
    return T


def matrix_to_quat_xyz(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(quaternion x, y, z, w; translation) of a 4x4 rigid transform."""
    T = np.asarray(T, dtype=np.float64)
    return Rotation.from_matrix(T[:3, :3]).as_quat(), T[:3, 3].copy()


__all__ = [
    "COLOR_ENCODINGS",
    "DEPTH_ENCODINGS",
    "SEG_ENCODING",
    "camera_info_k",
    "image_to_depth",
    "image_to_rgb",
    "image_to_seg",
    "matrix_to_quat_xyz",
    "stamp_ns",
    "transform_to_matrix",
]
