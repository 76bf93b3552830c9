"""Small RGB-D bags written with rosbags' own writer, laid out as a RealSense ROS 2 driver publishes
them (``/camera/camera/...``, 16UC1 millimetre aligned depth, ``/tf_static`` camera_link ->
camera_color_optical_frame), with knobs to break them in one way each."""

from __future__ import annotations

from pathlib import Path

import numpy as np

K = np.array([[120.0, 0.0, 80.0], [0.0, 120.0, 60.0], [0.0, 0.0, 1.0]])
W, H = 160, 120
# camera_link (x forward, z up) -> optical (z forward, x right, y down); 2 cm left of camera_link.
T_LINK_OPT = np.array([[0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.02], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def scene_depth_m() -> np.ndarray:
    """(H, W) metres: a wall at 0.8 m with a 0.6 m box in the middle and a hole of no reading."""
    d = np.full((H, W), 0.8, dtype=np.float32)
    d[40:80, 60:100] = 0.6
    d[0:5, 0:5] = 0.0
    return d


def write_realsense_bag(path: Path, frames: int = 5, color_encoding: str = "rgb8", depth_size: tuple[int, int] = (W, H),
                        depth_encoding: str = "16UC1", skip_depth: tuple[int, ...] = (), pad: int = 0) -> None:
    """Write ``frames`` colour/depth pairs at 10 Hz; depth stamps lag colour by 3 ms (unsynchronised
    drivers); frames listed in ``skip_depth`` have no depth. ``pad``: extra bytes per image row."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    from scipy.spatial.transform import Rotation

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    tmpdir = path.with_suffix(".dir")
    w = Writer(tmpdir, version=9, storage_plugin=StoragePlugin.MCAP)
    w.open()
    c_rgb = w.add_connection("/camera/camera/color/image_raw", "sensor_msgs/msg/Image", typestore=ts)
    c_d = w.add_connection("/camera/camera/aligned_depth_to_color/image_raw", "sensor_msgs/msg/Image", typestore=ts)
    c_info = w.add_connection("/camera/camera/color/camera_info", "sensor_msgs/msg/CameraInfo", typestore=ts)
    c_tf = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts)
    base = 1_700_000_000 * 10**9

    def header(ns: int, frame: str):
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                        frame_id=frame)

    def image(arr: np.ndarray, enc: str, ns: int):
        h, wd = arr.shape[:2]
        rows = arr.reshape(h, -1).view(np.uint8)
        if pad:
            rows = np.concatenate([rows, np.zeros((h, pad), np.uint8)], axis=1)
        return T["sensor_msgs/msg/Image"](header=header(ns, "camera_color_optical_frame"), height=h, width=wd,
                                          encoding=enc, is_bigendian=0, step=rows.shape[1],
                                          data=np.ascontiguousarray(rows).reshape(-1))

    q = Rotation.from_matrix(T_LINK_OPT[:3, :3]).as_quat()
    tf = T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
        header=header(base, "camera_link"), child_frame_id="camera_color_optical_frame",
        transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.02, z=0.0),
            rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])))])
    w.write(c_tf, base, ts.serialize_cdr(tf, "tf2_msgs/msg/TFMessage"))
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[40:80, 60:100] = (200, 30, 30)
    depth_m = scene_depth_m()
    dw, dh = depth_size
    if (dw, dh) != (W, H):
        depth_m = np.full((dh, dw), 0.8, np.float32)
    depth = np.round(depth_m * 1000).astype(np.uint16) if depth_encoding == "16UC1" else depth_m
    for i in range(frames):
        ns = base + i * 100_000_000
        color = rgb[:, :, ::-1] if color_encoding == "bgr8" else rgb
        enc_arr = np.repeat(rgb[:, :, :1], 2, axis=2) if color_encoding == "yuv422" else color
        w.write(c_rgb, ns, ts.serialize_cdr(image(np.ascontiguousarray(enc_arr), color_encoding, ns),
                                            "sensor_msgs/msg/Image"))
        info = T["sensor_msgs/msg/CameraInfo"](
            header=header(ns, "camera_color_optical_frame"), height=H, width=W, distortion_model="plumb_bob",
            d=np.zeros(5), k=K.reshape(-1), r=np.eye(3).reshape(-1), p=np.hstack([K, np.zeros((3, 1))]).reshape(-1),
            binning_x=0, binning_y=0, roi=T["sensor_msgs/msg/RegionOfInterest"](
                x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
        w.write(c_info, ns, ts.serialize_cdr(info, "sensor_msgs/msg/CameraInfo"))
        if i not in skip_depth:
            dns = ns + 3_000_000
            w.write(c_d, dns, ts.serialize_cdr(image(depth, depth_encoding, dns), "sensor_msgs/msg/Image"))
    w.close()
    (tmpdir / f"{tmpdir.name}.mcap").rename(path)
    for p in tmpdir.iterdir():
        p.unlink()
    tmpdir.rmdir()
