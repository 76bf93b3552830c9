"""Progress lines off a terminal: N/M with an ETA, at most one every 10 s, always the last."""

from __future__ import annotations

import io

from code_as_monitor.cli.progress import ProgressLines, is_terminal


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_at_most_one_line_every_10_s_and_always_the_last() -> None:
    clock, out = Clock(), io.StringIO()
    p = ProgressLines("cam bench", "episodes", every_s=10.0, stream=out, clock=clock)
    p.start(100)
    printed = []
    for done in range(1, 101):
        clock.t += 0.7  # an episode every 0.7 s: 70 s in all
        printed.append(p.update(done, f"e{done}"))
    lines = out.getvalue().splitlines()
    assert len(lines) == sum(printed) and 6 <= len(lines) <= 8  # 70 s / 10 s, plus the last
    assert lines[-1].startswith("cam bench: 100/100 episodes (100 %), 1.2 min elapsed") and "ETA" not in lines[-1]
    assert "e100" in lines[-1]
    first = lines[0]
    assert first.startswith("cam bench: 15/100 episodes (15 %), 0.2 min elapsed, ETA 1.0 min")


def test_eta_is_the_mean_rate_times_what_is_left() -> None:
    clock = Clock()
    p = ProgressLines("x", "items", clock=clock)
    p.start(4)
    clock.t = 120.0
    assert p.line(1) == "x: 1/4 items (25 %), 2.0 min elapsed, ETA 6.0 min"


def test_a_string_buffer_is_not_a_terminal() -> None:
    assert not is_terminal(io.StringIO())
