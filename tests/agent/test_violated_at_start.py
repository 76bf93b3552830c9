"""A ``during`` check already False on the subgoal's starting state, with the real sandbox and path coverage.

A program that path coverage drives both ways but whose constraint the world violates now is accepted, and
the violation is an alarm at once, with its reason, before the action starts: the planner re-plans on what
is wrong, the coder is not asked again. A check that no probe can make True is still a bad program: the
coder is re-asked and the subgoal ends in an error, with no alarm.
"""

from __future__ import annotations

import pytest
from loop_fakes import History, MovePolicy, Painter, Planner, Tracker, World, _subgoal, user_loop

from code_as_monitor.agent.code_checker import CodeChecker
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.decision import DecisionKind
from code_as_monitor.agent.monitor import Monitor
from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.runtime import MonitorRuntime

ATTACHED = {
    # the painted block is at z = 0: 0.0 m high, below the 5 mm the check asks; probes lift it above
    "possible": 'def check_attached(E, H, t):\n    z = float(E[0][:, 2].mean())\n'
                '    return bool(z > 0.005), f"block is {z:.3f} m high"\n',
    # no probe moves the block 10 m up: this check can never hold
    "impossible": 'def check_attached(E, H, t):\n    z = float(E[0][:, 2].mean())\n'
                  '    return bool(z > 10.0), f"block is {z:.3f} m high"\n',
}
ARRIVED = ('def check_arrived(E, H, t):\n    x = float(E[0][:, 0].mean())\n'
           '    return bool(x >= 0.01), f"x = {x:.2f} m"\n')


class Coder:
    """Writes the program for the subgoal's constraint ids; re-asked like the real coder after a rejection."""

    def __init__(self, attached: str) -> None:
        self.attached = attached
        self.asked: list[str] = []

    def write_program(self, subgoal, elements, images, check, max_retries=2, feedback=None):
        ids = {c.id for c in subgoal.constraints}
        source = (ATTACHED[self.attached] if "attached" in ids else "") + (ARRIVED if "arrived" in ids else "")
        last = None
        for _ in range(1 + max_retries):
            self.asked.append(subgoal.text)
            try:
                check(source)
                return source
            except ProgramError as exc:
                last = exc
        raise ProgramError(f"no acceptable program: {last}")


@pytest.fixture(scope="module")
def runtime():
    with MonitorRuntime(deadline_s=0.2, n_perturbations=24) as rt:
        yield rt


def _run(runtime: MonitorRuntime, attached: str) -> tuple[list, list, Planner, Coder, MovePolicy]:
    w = World()
    events: list = []

    def on_frame(obs, elements, stale, verdicts, banner) -> None:
        events.append(("frame", {"t": obs.t, "banner": banner, "verdicts": [v.constraint_id for v in verdicts]}))

    coder = Coder(attached)
    planner = Planner([_subgoal("move block"), _subgoal("move block again", during=False)])
    cfg = AgentConfig(code_retries=2)
    checker = CodeChecker(coder, Painter(), Tracker(w), runtime, History, cfg, on_frame=on_frame)
    monitor = Monitor(planner, checker, max_replans=3, on_event=lambda kind, **f: events.append((kind, f)))
    policy = MovePolicy(w)
    return user_loop(monitor, w, policy), events, planner, coder, policy


def test_a_check_violated_on_the_starting_state_is_an_alarm_at_once_not_a_rejection(runtime) -> None:
    decisions, events, planner, coder, policy = _run(runtime, "possible")
    first = decisions[0]
    assert coder.asked[0] == "move block" and coder.asked.count("move block") == 1, "the coder is not re-asked"
    assert [(a.constraint_id, a.phase, a.reason) for a in first.violations] == [
        ("attached", "during", "block is 0.000 m high")]
    assert first.violations[0].t == 0.0 and not first.violations[0].proactive
    assert first.ended.outcome == "violated" and first.ended.reason == "attached: block is 0.000 m high"
    assert first.kind is DecisionKind.SUBGOAL_FAILED and first.subgoal.text == "move block again"
    assert [a.args for a in policy.started] == [{"obj": "block"}], "the violated subgoal's action never started"
    assert planner.calls[1][1] == "failure: attached: block is 0.000 m high"
    kinds = [k for k, _ in events]
    assert "program_rejected" not in kinds and kinds.count("alarm") == 1
    verdict = next(f for k, f in events if k == "verdict")
    assert verdict["constraint_id"] == "attached" and verdict["ok"] is False
    frame = next(f for k, f in events if k == "frame")  # a video or live view shows the violation too
    assert frame == {"t": 0.0, "banner": "VIOLATION attached: block is 0.000 m high", "verdicts": ["attached"]}
    assert decisions[-1].kind is DecisionKind.TASK_DONE


def test_a_check_that_can_never_hold_is_still_rejected_and_the_coder_re_asked(runtime) -> None:
    decisions, events, planner, coder, _ = _run(runtime, "impossible")
    first = decisions[0]
    assert coder.asked.count("move block") == 3, "1 + code_retries programs asked for"
    assert first.violations == [] and first.ended.outcome == "error"
    assert "can never be satisfied" in first.ended.reason
    kinds = [k for k, _ in events]
    assert "program_rejected" in kinds and "alarm" not in kinds
    assert planner.calls[1][1].startswith("failure: no valid monitor program")
