"""Closed loop on screw-bulb from the front view alone (kb backend, sim segmenter, the default ``depth`` tracker, the
CLI's 640x480): the first screw seats the bulb, and the subgoal's end judges it where the tracker carried it.

Before, the bulb (at rest by ``refresh_motion``: it moved 1.5 cm, with a weak start paint from one view) was painted
afresh at the policy's end; with its neck inside the socket, that paint read its centre 42 mm above the socket's
(the kb's bound: 39), and every re-screw of the seated bulb ended on "not screwed in" until the time limit (seeds 8
and 21 of 0-21 failed so). Measured: about 8 s wall on 2 cores (beside a benchmark run).
"""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.bench.episode import BENCH_DEADLINE_S

pytest.importorskip("pybullet")


def test_screw_bulb_from_the_front_view_alone_ends_on_the_first_screw() -> None:
    s = run_closed_loop(ClosedLoopConfig(task="screw-bulb", seed=21, cameras="front", tracker="depth", width=640,
                                         height=480, deadline_s=BENCH_DEADLINE_S, video=False), None)
    assert s["success"], s["reason"]
    assert [sg["skill"] for sg in s["episode"]["subgoals"]][:2] == ["grasp", "screw"]
    assert not s["episode"]["alarms"], [a["reason"] for a in s["episode"]["alarms"]]
