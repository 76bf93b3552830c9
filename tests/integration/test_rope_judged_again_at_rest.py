"""Closed loop on rope-close-square seed 3 seen from the two shoulder cameras (kb backend, sim segmenter, ``depth``
tracker, 640x480: ``cam run rope-close-square --seed 3 --cameras shoulders``, with the benchmark's sandbox deadline):
a rope that slides open after the halt is judged again at rest.

Before (to ``bb81d25``) the monitor halted at 44.4 s on a closed opening, the rope slid 2.0 cm while the scene came to
rest, the check at rest was not judged (the elements had moved less than the 3 cm gate) and the task ended open
(coverage 0.64). With ``rest_motion`` 0 the check at rest reads 82 %, the planner pushes again and the monitor halts at
46.9 s on a closed opening. Measured: about 65 s wall, hence ``slow``.
"""

from __future__ import annotations

import pytest

from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop
from code_as_monitor.bench.episode import BENCH_DEADLINE_S

pytest.importorskip("pybullet")


@pytest.mark.slow
def test_a_rope_that_slides_open_after_the_halt_is_pushed_again() -> None:
    s = run_closed_loop(ClosedLoopConfig(task="rope-close-square", seed=3, cameras="shoulders", tracker="depth",
                                         width=640, height=480, deadline_s=BENCH_DEADLINE_S, video=False), None)
    assert s["success"], s["reason"]
