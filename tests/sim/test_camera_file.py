"""``--cameras FILE.json``: a user's own views, loaded into camera specs, every bad value a ConfigError naming it,
and an episode seen from them."""

from __future__ import annotations

import json

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, check_choices, run_closed_loop
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.camera_file import load_camera_file
from code_as_monitor.sim.cameras import CameraSpec, camera_set

VIEWS = [
    {"name": "left_low", "eye": [0.55, 0.75, 0.40], "target": [0.5, 0.0, 0.05], "fov_y_deg": 55},
    {"name": "top", "eye": [0.5, 0.0, 1.5], "target": [0.5, 0.0, 0.0], "width": 200, "height": 150},
]


def _write(tmp_path, data, name="views.json"):
    p = tmp_path / name
    p.write_text(json.dumps(data))
    return p


def test_a_file_gives_its_cameras_with_the_default_size_where_none_is_given(tmp_path):
    specs = camera_set(str(_write(tmp_path, {"cameras": VIEWS})), 320, 240)
    assert [s.name for s in specs] == ["left_low", "top"]
    assert (specs[0].width, specs[0].height, specs[0].fov_y_deg) == (320, 240, 55.0)
    assert (specs[1].width, specs[1].height, specs[1].fov_y_deg) == (200, 150, 50.0)
    assert specs[0].eye == (0.55, 0.75, 0.40) and specs[0].mount == "world"
    listed = load_camera_file(_write(tmp_path, VIEWS, "list.json"), 64, 48, CameraSpec)
    assert [s.name for s in listed] == ["left_low", "top"]


@pytest.mark.parametrize("cams, needle", [
    ([], "non-empty list"),
    ([{"name": "a", "eye": [1, 0, 1]}], "missing 'target'"),
    ([{"name": "a", "eye": [1, 0, 1], "target": [0, 0, 0], "fov": 40}], "unknown field(s) 'fov'"),
    ([{"name": "a", "eye": [1, 0], "target": [0, 0, 0]}], "eye must be 3 finite numbers"),
    ([{"name": "a", "eye": [1, 0, 1e400], "target": [0, 0, 0]}], "eye must be 3 finite numbers"),
    ([{"name": "a", "eye": [1, 0, 1], "target": [0, 0, "x"]}], "target must be 3 finite numbers"),
    ([{"name": "a", "eye": [1, 0, 1], "target": [0, 0, 0], "fov_y_deg": 200}], "fov_y_deg must be in"),
    ([{"name": "a", "eye": [1, 0, 1], "target": [0, 0, 0], "width": 0}], "width must be an integer"),
    ([{"name": "a", "eye": [1, 0, 1], "target": [0, 0, 0], "mount": "ceiling"}], "mount must be one of"),
    ([{"name": "a", "eye": [1, 0, 1], "target": [1, 0, 1]}], "eye and target are the same point"),
    ([{"name": "", "eye": [1, 0, 1], "target": [0, 0, 0]}], "name must be a non-empty string"),
    ([VIEWS[0], VIEWS[0]], "'left_low' is used twice"),
    (["front"], "camera 0 must be an object"),
])
def test_every_bad_value_is_a_config_error_naming_it(tmp_path, cams, needle):
    p = _write(tmp_path, cams)
    with pytest.raises(ConfigError) as e:
        camera_set(str(p), 320, 240)
    assert needle in str(e.value) and str(p) in str(e.value), str(e.value)


def test_a_missing_or_broken_file_names_itself(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        camera_set(str(tmp_path / "nope.json"), 320, 240)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ConfigError, match="is not JSON"):
        check_choices(ClosedLoopConfig(task="stack-in-order", cameras=str(bad)))


def test_an_ablation_that_keeps_the_front_view_needs_one_in_the_file(tmp_path):
    p = str(_write(tmp_path, VIEWS))
    with pytest.raises(ConfigError, match="front"):
        check_choices(ClosedLoopConfig(task="stack-in-order", cameras=p, ablation="mv-off"))


def test_an_episode_from_the_files_views_sees_only_them_and_records_them(tmp_path):
    p = str(_write(tmp_path, VIEWS))
    seen: set[str] = set()
    cfg = ClosedLoopConfig(task="stack-in-order", seed=0, tracker="depth", cameras=p, video=False,
                           max_replans=10, deadline_s=0.5)
    out = run_closed_loop(cfg, run_dir=tmp_path / "run", frame_hooks=[lambda obs, *_: seen.update(obs.views)])
    assert seen == {"left_low", "top"}
    assert [c["name"] for c in out["camera_specs"]] == ["left_low", "top"]
    assert out["camera_specs"][1]["width"] == 200
    assert out["success"], out.get("reason")


def test_the_cli_says_what_is_wrong_with_a_file_in_one_line_and_exits_2(tmp_path, capsys):
    from code_as_monitor.cli.main import main

    p = _write(tmp_path, [{"name": "a", "eye": [1, 0, 1], "target": [0, 0, 0], "fov": 40}])
    assert main(["run", "stack-in-order", "--cameras", str(p), "--runs", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown field(s) 'fov'" in err[0]
    assert not (tmp_path / "runs").exists()


def test_cam_sim_renders_a_video_from_the_files_views(tmp_path):
    """``cam sim --cameras FILE --video`` is how a user looks at a camera file before running the monitor on it."""
    import imageio.v3 as iio

    from code_as_monitor.cli.main import main

    p = _write(tmp_path, [dict(VIEWS[0], width=160, height=120), dict(VIEWS[1], width=160, height=120)])
    out = tmp_path / "views.mp4"
    assert main(["sim", "stack-in-order", "--cameras", str(p), "--video", str(out), "--set", "time_limit=2"]) == 0
    frame = iio.imread(out, index=0)
    assert frame.shape[1] >= 2 * 150  # both views, side by side
