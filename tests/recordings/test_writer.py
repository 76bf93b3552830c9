"""BagWriter -> BagSource round trip on constructed observations (no simulator), and partial writes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import RecordingError
from code_as_monitor.core.observation import Observation, RobotState, View
from code_as_monitor.geometry.transforms import make_transform, rotation_about
from code_as_monitor.recordings.reader import BagSource
from code_as_monitor.recordings.writer import BagWriter


def _obs(t: float, w: int = 40, h: int = 30) -> Observation:
    cam = CameraModel.look_at("front", np.array([0.8, 0.1, 0.6]), np.zeros(3), w, h, 55.0)
    rng = np.random.default_rng(int(t * 10))
    rgb = rng.integers(0, 255, (h, w, 3), dtype=np.uint8)
    depth = rng.uniform(0.3, 1.5, (h, w)).astype(np.float32)
    depth[0, 0] = np.nan
    seg = np.zeros((h, w), np.int32)
    seg[5:10, 5:10] = 7
    ee = make_transform(rotation_about([1, 1, 0], 0.3 + t), [0.1, -0.2, 0.3 + t])
    robot = RobotState(ee_pose=ee, gripper=1.0, ee_kind="suction", ee_points={"tip": ee[:3, 3]},
                       joints=np.linspace(0, 1, 7))
    return Observation(t, {"front": View(rgb, depth, cam, seg=seg, seg_labels={7: ("red_block", "")})}, robot,
                       objects=["red_block", "table"], object_poses={"red_block": make_transform(t=[0.0, 0.1, 0.02])})


@pytest.mark.parametrize(("name", "encoding", "tol"), [("ep.mcap", "32FC1", 0.0), ("ep.db3", "16UC1", 0.0006),
                                                       ("epdir", "32FC1", 0.0)])
def test_round_trip(tmp_path: Path, name: str, encoding: str, tol: float) -> None:
    out = tmp_path / name
    w = BagWriter(out, depth_encoding=encoding, metadata={"instruction": "pick it"})
    frames = [_obs(0.1 * i) for i in range(3)]
    for i, o in enumerate(frames):
        w.write_observation(o, policy_done=i == 2)
    w.write_event({"t": 0.15, "kind": "drop", "obj": "red_block"})
    assert w.close() == out and out.exists()
    assert [p.name for p in tmp_path.iterdir()] == [name], "no temporary left behind"
    src = BagSource(out)
    assert src.metadata["instruction"] == "pick it" and src.ground_truth[0]["kind"] == "drop"
    got = list(src)
    assert [d for _, d in got] == [False, False, True]
    for (o, _), ref in zip(got, frames):
        v, rv = o.views["front"], ref.views["front"]
        assert o.t == pytest.approx(ref.t, abs=1e-9)
        np.testing.assert_array_equal(v.rgb, rv.rgb)
        np.testing.assert_allclose(v.depth, np.nan_to_num(rv.depth), atol=tol)
        np.testing.assert_array_equal(v.seg, rv.seg)
        assert v.seg_labels == {7: ("red_block", "")}
        np.testing.assert_allclose(v.camera.K, rv.camera.K)
        np.testing.assert_allclose(v.camera.T_world_cam, rv.camera.T_world_cam, atol=1e-12)
        np.testing.assert_allclose(o.robot.ee_pose, ref.robot.ee_pose, atol=1e-12)
        np.testing.assert_allclose(o.robot.joints, ref.robot.joints)
        assert o.robot.gripper == 1.0 and o.robot.ee_kind == "suction"
        np.testing.assert_allclose(o.object_poses["red_block"], ref.object_poses["red_block"], atol=1e-12)
        assert o.objects == ["red_block", "table"]


def test_an_abandoned_write_leaves_nothing_that_looks_complete(tmp_path: Path) -> None:
    out = tmp_path / "ep.mcap"
    w = BagWriter(out)
    w.write_observation(_obs(0.0), False)
    assert not out.exists(), "only a hidden .partial name exists while writing"
    assert w.close(complete=False) is None
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(RecordingError, match="exists already"):
        out.write_bytes(b"x")
        BagWriter(out)
