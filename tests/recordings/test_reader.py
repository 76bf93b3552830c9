"""Reading bags laid out as other tools write them, and every way a bag can be unusable."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from synth_bags import T_LINK_OPT, K, scene_depth_m, write_realsense_bag

from code_as_monitor.cli.main import main
from code_as_monitor.core.errors import RecordingError
from code_as_monitor.recordings.reader import BagSource


@pytest.mark.parametrize("color_encoding", ["rgb8", "bgr8"])
def test_a_realsense_bag_with_16uc1_depth_is_read(tmp_path: Path, color_encoding: str) -> None:
    bag = tmp_path / "rs.mcap"
    write_realsense_bag(bag, color_encoding=color_encoding, pad=8)
    src = BagSource(bag)  # the RealSense default topic map
    assert len(src) == 5 and src.stats.dropped_total == 0, "depth 3 ms behind colour is within the tolerance"
    frames = list(src)
    obs, done = frames[0]
    assert not done and obs.robot is None and obs.t == 0.0 and frames[-1][0].t == pytest.approx(0.4)
    v = obs.views["camera"]
    assert v.rgb.shape == (120, 160, 3) and tuple(v.rgb[60, 80]) == (200, 30, 30)
    assert v.depth.dtype == np.float32
    np.testing.assert_allclose(v.depth, scene_depth_m(), atol=0.0006)
    assert v.depth[0, 0] == 0.0, "0 stays 'no reading'"
    np.testing.assert_allclose(v.camera.K, K)
    np.testing.assert_allclose(v.camera.T_world_cam, T_LINK_OPT, atol=1e-9)


def test_frames_without_a_depth_partner_are_dropped_and_counted(tmp_path: Path) -> None:
    bag = tmp_path / "rs.mcap"
    write_realsense_bag(bag, frames=6, skip_depth=(2, 4))
    src = BagSource(bag)
    assert len(src) == 4 and src.stats.dropped_total == 2
    assert src.stats.dropped["camera/depth"] == 2
    assert [round(o.t, 3) for o, _ in src] == [0.0, 0.1, 0.3, 0.5]


def _truncate(p: Path) -> None:
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])


def _garble(p: Path) -> None:
    p.write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 40)


BAD = [
    ("truncated", lambda p: (write_realsense_bag(p), _truncate(p)), [], "cannot read bag"),
    ("corrupt", _garble, [], "cannot read bag"),
    ("missing file", lambda p: None, [], "no such file"),
    ("size mismatch", lambda p: write_realsense_bag(p, depth_size=(80, 60)), [], "does not match colour"),
    ("unknown encoding", lambda p: write_realsense_bag(p, color_encoding="yuv422"), [], "'yuv422'"),
    ("missing topic", lambda p: write_realsense_bag(p), ["--topics", "MAP"], "has no topic '/wrist/color'"),
]


@pytest.mark.parametrize(("what", "make", "extra", "message"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_bag_is_one_line_exit_2_and_nothing_written(tmp_path: Path, capsys, what, make, extra, message) -> None:
    bag = tmp_path / "bad.mcap"
    make(bag)
    topic_map = tmp_path / "map.yaml"
    topic_map.write_text("world_frame: camera_link\nviews:\n  wrist:\n    color: /wrist/color\n"
                         "    depth: /wrist/depth\n    camera_info: /wrist/info\n")
    extra = [str(topic_map) if a == "MAP" else a for a in extra]
    runs = tmp_path / "runs"
    rc = main(["monitor", str(bag), "--instruction", "stack the blocks", "--runs", str(runs), *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], (rc, err)
    assert "Traceback" not in err[0]
    assert not runs.exists()


def test_library_errors_are_recording_errors(tmp_path: Path) -> None:
    bag = tmp_path / "rs.mcap"
    write_realsense_bag(bag, depth_encoding="32FC1", depth_size=(80, 60))
    with pytest.raises(RecordingError, match="registered to the colour image"):
        BagSource(bag)


def test_a_bad_topic_map_names_the_key(tmp_path: Path, capsys) -> None:
    bag = tmp_path / "rs.mcap"
    write_realsense_bag(bag)
    m = tmp_path / "m.yaml"
    m.write_text("views:\n  cam:\n    color: /a\n    depth: /b\n    camera_info: /c\nsync_tolerence_s: 0.1\n")
    assert main(["monitor", str(bag), "--instruction", "x", "--topics", str(m), "--runs", str(tmp_path / "r")]) == 2
    assert "unknown key 'sync_tolerence_s'" in capsys.readouterr().err
