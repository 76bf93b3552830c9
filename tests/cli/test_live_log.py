"""The live log of ``cam run``: the done check at rest is shown, with its verdict."""

from __future__ import annotations

import io

from rich.console import Console

from code_as_monitor.cli.live_log import LiveLog


def test_the_done_check_at_rest_is_shown_with_its_verdict() -> None:
    out = io.StringIO()
    log = LiveLog(Console(file=out, width=200, color_system=None))
    log({"kind": "task_complete_claimed", "t": 9.7, "checking": "the last subgoal's upon checks at rest"})
    log({"kind": "rest_check", "t": 10.2, "ok": False, "remeasured": [], "verdicts": []})
    log({"kind": "rest_check", "t": 15.7, "ok": True, "remeasured": [], "verdicts": []})
    log({"kind": "rest_check", "t": 20.7, "ok": True, "judged": False, "moved": 0.0098})
    lines = out.getvalue().splitlines()
    assert "9.70s" in lines[0] and "judging the last subgoal again at rest" in lines[0]
    assert "10.20s" in lines[1] and "no longer holds at rest" in lines[1]
    assert "15.70s" in lines[2] and "still holds at rest" in lines[2]
    assert "20.70s" in lines[3] and "moved 10 mm since it was judged" in lines[3]
