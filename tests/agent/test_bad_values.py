"""Library entry points refuse bad values with the project's exceptions, naming the value.

A hostile caller passes NaN, inf, denormals, huge numbers, strings, bools and None where numbers go, and
non-observations to the streaming API: each is a ConfigError / ObservationError / SandboxError /
RecordingError whose message holds the offending field or value, never a TypeError from deep inside.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from code_as_monitor.agent.config import MonitorConfig
from code_as_monitor.agent.monitor import build_monitor
from code_as_monitor.bench.closed_loop import ClosedLoopConfig
from code_as_monitor.core.errors import ConfigError, ObservationError, RecordingError, SandboxError
from code_as_monitor.monitor.sandbox import Sandbox

MONITOR_CONFIG_BAD = [
    ("frame_hz", math.inf), ("frame_hz", "10"), ("frame_hz", None), ("frame_hz", 1e-320), ("frame_hz", 1e300),
    ("frame_hz", True), ("max_replans", 1.5), ("max_replans", "3"), ("max_replans", math.nan),
    ("max_subgoals", 0), ("max_subgoals", "x"), ("time_limit_s", math.inf), ("time_limit_s", "x"),
    ("history_len", 2.5), ("history_len", math.inf), ("code_retries", 0.5), ("halt_on_upon", "no"),
    ("upon_dwell_frames", math.nan), ("refresh_motion", -1.0), ("refresh_motion", "x"), ("settle_frames", 1.5),
    ("rest_motion", -0.01), ("rest_motion", math.inf),
    ("deadline_s", math.inf), ("deadline_s", 1e300), ("deadline_s", 1e-320), ("deadline_s", "x"),
    ("backend_options", "x"), ("tracker_options", [1]), ("cameras", "front"), ("backend", 3),
]


@pytest.mark.parametrize(("field", "value"), MONITOR_CONFIG_BAD, ids=[f"{f}={v!r}" for f, v in MONITOR_CONFIG_BAD])
def test_monitor_config_refuses(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        MonitorConfig(**{field: value})


CLOSED_LOOP_BAD = [("width", 100_000), ("width", 1.5), ("height", "x"), ("camera_hz", 1e-320), ("camera_hz", 41.0),
                   ("deadline_s", 1e300), ("seed", True), ("task_params", "x"), ("video", "yes")]


@pytest.mark.parametrize(("field", "value"), CLOSED_LOOP_BAD, ids=[f"{f}={v!r}" for f, v in CLOSED_LOOP_BAD])
def test_closed_loop_config_refuses(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        ClosedLoopConfig(**{field: value})


@pytest.mark.parametrize("kw", [{"camera_hz": 1e-320}, {"camera_hz": 1e300}, {"width": 0}, {"width": "x"},
                                {"height": 10**9}, {"control_hz": "x"}, {"physics_hz": 0}])
def test_world_config_refuses(kw: dict) -> None:
    from code_as_monitor.sim.world import WorldConfig

    with pytest.raises(ConfigError, match=next(iter(kw))):
        WorldConfig(**kw)


@pytest.mark.parametrize("kw", [{"deadline_s": math.inf}, {"deadline_s": 1e300}, {"deadline_s": "x"},
                                {"deadline_s": 1e-320}, {"memory_mb": "x"}, {"spares": 0.5}])
def test_sandbox_limits_refused_before_any_worker(kw: dict) -> None:
    with pytest.raises(SandboxError, match=next(iter(kw))):
        Sandbox(**kw)


def test_streaming_api_refuses_what_is_not_an_observation() -> None:
    from code_as_monitor.core.camera import CameraModel
    from code_as_monitor.core.observation import Observation, View

    m = build_monitor(MonitorConfig())
    try:
        m.start("stack the blocks: red at the bottom, then green, then blue")
        for bad in (None, "frame", 3):
            with pytest.raises(ObservationError, match=type(bad).__name__):
                m.step(bad)  # type: ignore[arg-type]
        cam = CameraModel("front", 32, 32, np.array([[30.0, 0, 16], [0, 30.0, 16], [0, 0, 1]]), np.eye(4))
        view = View(np.zeros((32, 32, 3), np.uint8), np.ones((32, 32), np.float32), cam)
        for t in (math.nan, math.inf, "0.1", True):
            with pytest.raises(ObservationError, match="finite"):
                m.step(Observation(t=t, views={"front": view}))  # type: ignore[arg-type]
        with pytest.raises(ObservationError, match="dict of views"):
            m.step(Observation(t=0.0, views=[view]))  # type: ignore[arg-type]
        with pytest.raises(ObservationError, match=r"'front'.*not a View"):
            m.step(Observation(t=0.0, views={"front": "img"}))  # type: ignore[dict-item]
        with pytest.raises(ObservationError, match="nan"):
            m.frame_due(math.nan)
        with pytest.raises(ObservationError, match="rgb must be a numpy array"):
            View([[0]], np.ones((32, 32)), cam)  # type: ignore[arg-type]
    finally:
        m.close()


@pytest.mark.parametrize("path", [None, 3, ""])
def test_bag_source_refuses_a_non_path(path: object) -> None:
    pytest.importorskip("rosbags")
    from code_as_monitor.recordings.reader import BagSource

    with pytest.raises(RecordingError, match=re.escape(repr(path)) if path != "" else "non-empty"):
        BagSource(path)  # type: ignore[arg-type]


def test_read_jsonl_tells_a_torn_write_from_a_bad_file(tmp_path: Path) -> None:
    from code_as_monitor.core.errors import RunError
    from code_as_monitor.core.run_io import read_jsonl

    f = tmp_path / "r.jsonl"
    f.write_text('{"a": 1}\n{"b": ')  # a killed writer: the last line has no newline
    assert read_jsonl(f) == [{"a": 1}]
    for text in ("not json\n", "not json", '{"a": 1}\nnot json\n'):
        f.write_text(text)
        with pytest.raises(RunError, match="not valid JSON"):
            read_jsonl(f)
