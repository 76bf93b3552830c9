"""Closed-loop recovery on pour-tea: on a fixed seed per disturbance kind, Code-as-Monitor (kb backend, sim
segmenter, sim tracker, 320x240) raises the expected first alarm and recovers.

(a) and (c) fail open loop; (b), the sideways tilt, does not (the lid keeps the tea in and the funnel spout pours it
into the cup regardless; see ``sim/tasks/pour_tea.py``), but it violates "keep it level", and CaM sets the pot down
and grasps it again (the wrist cannot undo a sideways tilt).

Measured (seed 0, 2 cores): (a) about 12 s wall plus 4 s open loop alone, 32 s while a benchmark ran on the other
core; (b) 45 s and (c) 43 s under the same load.
"""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.bench.episode import BENCH_DEADLINE_S
from code_as_monitor.sim.episode import run_open_loop

SEED = 0
EXPECTED_ALARM = {"a": "potlevel_teapot", "b": "potlevel_teapot", "c": "pourtilt_teapot"}


def _closed_loop(disturbance: str) -> dict:
    s = run_closed_loop(ClosedLoopConfig(
        deadline_s=BENCH_DEADLINE_S, task="pour-tea", seed=SEED, task_params={"disturbance": disturbance},
                                         tracker="sim", video=False), None)
    alarms = [a["constraint_id"] for a in s["episode"]["alarms"]]
    assert alarms and alarms[0] == EXPECTED_ALARM[disturbance]
    assert s["success"], s["reason"]
    assert s["episode"]["finished"]
    return s


def test_pour_tea_recovers_when_the_pot_tips_forward_in_transport():
    assert not run_open_loop("pour-tea", seed=SEED, disturbance="a").success
    _closed_loop("a")


@pytest.mark.slow
def test_pour_tea_recovers_when_the_pour_is_undone():
    assert not run_open_loop("pour-tea", seed=SEED, disturbance="c").success
    _closed_loop("c")


@pytest.mark.slow
def test_pour_tea_sets_the_pot_down_when_it_tips_sideways():
    s = _closed_loop("b")
    skills = [(r["skill"], r["outcome"]) for r in s["episode"]["subgoals"]]
    assert ("set_down", "success") in skills
