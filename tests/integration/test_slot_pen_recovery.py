"""Closed-loop recovery on slot-pen: on a fixed seed per disturbance kind, the open-loop policy fails and
Code-as-Monitor (kb backend, sim segmenter, sim tracker, 320x240) detects the failure and recovers.

Measured (2 cores): (c) holder moved during insertion about 10 s wall; (a) and (b) 15-17 s each (slow).
"""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.bench.episode import BENCH_DEADLINE_S
from code_as_monitor.sim.episode import run_open_loop

SEED = 0
EXPECTED_ALARM = {"a": "steady_pen", "b": "carried_pen", "c": "over_pen_holder"}


def _recovers(disturbance: str) -> None:
    assert not run_open_loop("slot-pen", seed=SEED, disturbance=disturbance).success
    s = run_closed_loop(ClosedLoopConfig(
        deadline_s=BENCH_DEADLINE_S, task="slot-pen", seed=SEED, task_params={"disturbance": disturbance},
                                         tracker="sim", video=False), None)
    alarms = [a["constraint_id"] for a in s["episode"]["alarms"]]
    assert alarms and alarms[0] == EXPECTED_ALARM[disturbance]
    assert s["success"], s["reason"]
    assert s["episode"]["finished"]


def test_slot_pen_recovers_when_the_holder_moves_during_insertion():
    _recovers("c")


@pytest.mark.slow
@pytest.mark.parametrize("disturbance", ["a", "b"])
def test_slot_pen_recovers_from_grasp_shift_and_drop(disturbance):
    _recovers(disturbance)
