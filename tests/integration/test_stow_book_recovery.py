"""Closed-loop recovery on stow-book: on a fixed seed per disturbance kind, the open-loop policy fails and
Code-as-Monitor (kb backend, sim segmenter, sim tracker, 320x240) detects the failure and recovers.

Measured (2 cores, seed 0): (b) book tilted in transport about 8 s wall, (a) about 19 s, (c) about 13 s.
"""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.bench.episode import BENCH_DEADLINE_S
from code_as_monitor.sim.episode import run_open_loop

SEED = 0
EXPECTED_ALARM = {"a": "aligned_book", "b": "poised_book", "c": "conveyed_book"}


def _recovers(disturbance: str) -> None:
    assert not run_open_loop("stow-book", seed=SEED, disturbance=disturbance).success
    s = run_closed_loop(ClosedLoopConfig(
        deadline_s=BENCH_DEADLINE_S, task="stow-book", seed=SEED, task_params={"disturbance": disturbance},
                                         tracker="sim", video=False), None)
    alarms = [a["constraint_id"] for a in s["episode"]["alarms"]]
    assert alarms and alarms[0] == EXPECTED_ALARM[disturbance]
    assert s["success"], s["reason"]
    assert s["episode"]["finished"]


def test_stow_book_recovers_when_the_book_tilts_in_transport():
    _recovers("b")


@pytest.mark.slow
@pytest.mark.parametrize("disturbance", ["a", "c"])
def test_stow_book_recovers_from_turn_and_knock(disturbance):
    _recovers(disturbance)


def test_a_book_regrasped_with_its_spine_away_from_the_cameras_is_stowed():
    """Stow-book (c), episode seed 476548990 (table2-round3's one failed CaM book-c episode): after the knock and the
    re-grasp the book stands upright in the gripper with its spine behind the cover; the painter sees only the spine's
    end. At 48a8f99 the remembered spine was refused (its skin moved without turning) and the agent re-oriented an
    upright book to the re-plan bound (31 re-plans, failed). 64 s wall measured beside a benchmark on the same
    2 cores."""
    s = run_closed_loop(ClosedLoopConfig(
        deadline_s=BENCH_DEADLINE_S, task="stow-book", seed=476548990, task_params={"disturbance": "c"},
        tracker="sim", video=False), None)
    assert s["success"], s["reason"]
    upright = [a for a in s["episode"]["alarms"] if a["constraint_id"] == "upright_book"]
    assert not upright, upright[:2]
