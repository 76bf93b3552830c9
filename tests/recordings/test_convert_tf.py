"""Message conversions and TF lookups on constructed messages."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from code_as_monitor.core.errors import RecordingError
from code_as_monitor.geometry.transforms import make_transform, rotation_about
from code_as_monitor.recordings.convert import image_to_depth, image_to_rgb, matrix_to_quat_xyz, transform_to_matrix
from code_as_monitor.recordings.tf import TFBuffer


def _msg(arr: np.ndarray, enc: str, big: bool = False) -> SimpleNamespace:
    a = arr.astype(arr.dtype.newbyteorder(">")) if big else arr
    h, w = arr.shape[:2]
    return SimpleNamespace(encoding=enc, height=h, width=w, step=a.strides[0], is_bigendian=int(big),
                           data=np.ascontiguousarray(a).reshape(-1).view(np.uint8))


@pytest.mark.parametrize("big", [False, True])
def test_16uc1_millimetres_either_endianness(big: bool) -> None:
    mm = np.array([[0, 1, 800], [1500, 65535, 2]], dtype=np.uint16)
    np.testing.assert_allclose(image_to_depth(_msg(mm, "16UC1", big), "/d"), mm * 0.001, rtol=1e-6)


def test_32fc1_nan_and_inf_become_no_reading() -> None:
    d = np.array([[0.5, np.nan], [np.inf, 1.25]], dtype=np.float32)
    np.testing.assert_array_equal(image_to_depth(_msg(d, "32FC1"), "/d"), [[0.5, 0.0], [0.0, 1.25]])


def test_colour_encodings_and_errors() -> None:
    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    np.testing.assert_array_equal(image_to_rgb(_msg(rgb[:, :, ::-1].copy(), "bgr8"), "/c"), rgb)
    with pytest.raises(RecordingError, match="'mono8'"):
        image_to_rgb(_msg(rgb[:, :, 0].copy(), "mono8"), "/c")
    short = _msg(rgb, "rgb8")
    short.data = short.data[:5]
    with pytest.raises(RecordingError, match="does not hold"):
        image_to_rgb(short, "/c")


def test_transform_round_trip() -> None:
    T = make_transform(rotation_about([0.3, -0.2, 0.9], 1.1), [0.1, -0.4, 0.7])
    q, p = matrix_to_quat_xyz(T)
    tr = SimpleNamespace(translation=SimpleNamespace(x=p[0], y=p[1], z=p[2]),
                         rotation=SimpleNamespace(x=q[0], y=q[1], z=q[2], w=q[3]))
    np.testing.assert_allclose(transform_to_matrix(tr), T, atol=1e-12)


def test_tf_lookup_through_a_chain_both_ways_and_over_time() -> None:
    tf = TFBuffer()
    A = make_transform(rotation_about([0, 0, 1], 0.5), [1.0, 0, 0])
    tf.add("world", "base", A, 0, static=True)
    for i in range(3):
        tf.add("base", "/tool", make_transform(np.eye(3), [0, 0, 0.1 * i]), i * 100, static=False)
    np.testing.assert_allclose(tf.lookup("world", "tool", 150), A @ make_transform(np.eye(3), [0, 0, 0.1]))
    np.testing.assert_allclose(tf.lookup("tool", "world", 250) @ tf.lookup("world", "tool", 250), np.eye(4),
                               atol=1e-12)
    with pytest.raises(RecordingError, match="no TF path from frame 'camera'"):
        tf.lookup("world", "camera", 0)
