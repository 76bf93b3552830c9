"""Which alarms get a counterfactual rollout: every proactive one, and a reactive one no logged failure explains.

A reactive alarm halts the policy; the RLBench-style tasks judge a skill when it ends, so a halt can come before
a failure it saw is ever logged (put-in-drawer 1789404694: a block caught on the drawer's front and pulled from
the grip, no failure logged; its rollout then showed the block going into the drawer anyway). Such an alarm gets
the proactive alarms' rollout; one that a logged failure of its objects explains does not (the matching window: up
to ``WINDOW_S`` before it, or ``EARLY_S`` after).
"""

from __future__ import annotations

from code_as_monitor.bench.episode import unexplained
from code_as_monitor.bench.metrics import EARLY_S, WINDOW_S


def _alarm(t: float, objects: list[str], proactive: bool = False) -> dict:
    return {"kind": "alarm", "t": t, "proactive": proactive, "objects": objects}


def test_a_reactive_alarm_with_no_failure_logged_is_unexplained():
    gt = [{"t": 4.6, "kind": "action_start", "obj": "block"}, {"t": 6.2, "kind": "gripper_close", "obj": "block"}]
    assert unexplained(_alarm(8.2, ["block", "drawer_cabinet", "robot"]), gt)


def test_a_failure_of_its_object_in_the_window_explains_it():
    drop = {"t": 5.0, "kind": "drop", "obj": "green_block"}
    assert not unexplained(_alarm(5.3, ["green_block", "robot"]), [drop])
    assert not unexplained(_alarm(5.0 - EARLY_S + 0.01, ["green_block"]), [drop])  # the frame clock's slack
    assert unexplained(_alarm(5.0 + WINDOW_S + 0.1, ["green_block"]), [drop])  # too long after
    assert unexplained(_alarm(5.3, ["red_block"]), [drop])  # another object's failure explains nothing
    merged = {"t": 3.0, "kind": "policy_failure", "obj": "drawer_cabinet", "objects": ["drawer_cabinet", "block"]}
    assert not unexplained(_alarm(3.4, ["block"]), [merged])  # an object the failure names


def test_a_proactive_alarm_is_never_unexplained_it_always_gets_its_rollout():
    assert not unexplained(_alarm(2.0, ["red_block"], proactive=True), [])
