"""Closed loop on rope-close-square seed 130311453 (kb backend, sim segmenter, the default ``depth`` tracker, the
benchmark's 320x240 views): the check over the rope's beads is not judged on the beads seen while the suction holds
the rope.

Before (``3145548`` to ``befb665``), 0.2 s after the suction took the rope for a third push, the check held on the 17
beads seen (three stale), the policy was halted with the suction still on, and the opening, enclosed since 5.0 s,
ended 55 % covered; with the rule the push goes on and the monitor halts at 7.7 s on a closed opening. Measured: about
7 s wall.
"""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.bench.episode import BENCH_DEADLINE_S

pytest.importorskip("pybullet")


def test_the_rope_is_not_called_closed_on_the_beads_seen_while_the_suction_holds_it() -> None:
    s = run_closed_loop(ClosedLoopConfig(task="rope-close-square", seed=130311453, tracker="depth", width=320,
                                         height=240, camera_hz=10.0, max_replans=30, deadline_s=BENCH_DEADLINE_S,
                                         video=False), None)
    assert s["success"], s["reason"]
