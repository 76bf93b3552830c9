"""Metrics and confidence intervals on constructed results (no simulator)."""

from __future__ import annotations

import math

import pytest

from code_as_monitor.bench.metrics import (
    FAILURE_KINDS,
    benign,
    cell_summary,
    concerns,
    detection,
    detection_v1,
    failures,
    match,
    mean_ci,
    seed_level,
    t_quantile,
)


def _rec(seed: int, success: bool, t: float = 10.0, alarms=(), gt=(), episode: int = 0) -> dict:
    return {"seed": seed, "episode": episode, "success": success, "sim_time_s": t, "alarms": list(alarms),
            "gt": list(gt), "vlm": {"calls": 2, "total_tokens": 100}, "wall_time_s": 1.0}


def test_t_interval_matches_hand_computation():
    mean, hw = mean_ci([80.0, 100.0, 90.0, 70.0, 60.0])
    assert mean == pytest.approx(80.0)
    sd = math.sqrt(sum((x - 80.0) ** 2 for x in [80, 100, 90, 70, 60]) / 4)
    assert t_quantile(5) == pytest.approx(2.7764, abs=1e-3)
    assert hw == pytest.approx(2.7764451 * sd / math.sqrt(5), rel=1e-5)


def test_ci_degenerate_cases():
    assert math.isnan(mean_ci([])[0])
    m, hw = mean_ci([3.0])
    assert m == 3.0 and math.isnan(hw)
    assert mean_ci([5.0, 5.0, 5.0]) == (5.0, 0.0)


def test_success_rate_is_mean_of_per_seed_rates():
    # seed 0: 3/4, seed 1: 1/4, seed 2: 2/4 -> 75, 25, 50
    recs = []
    for seed, wins in ((0, 3), (1, 1), (2, 2)):
        recs += [_rec(seed, i < wins, episode=i) for i in range(4)]
    s = seed_level(recs, "success")
    assert s["ci_over"] == "seeds" and s["n"] == 3
    assert s["mean"] == pytest.approx(50.0)
    assert s["ci"] == pytest.approx(mean_ci([75.0, 25.0, 50.0])[1])


def test_single_seed_interval_is_over_episodes():
    s = seed_level([_rec(0, ok, episode=i) for i, ok in enumerate([True, False, True, True])], "success")
    assert s["ci_over"] == "episodes" and s["n"] == 4 and s["mean"] == pytest.approx(75.0)


def test_failures_merge_collapses_and_skip_block_fell():
    gt = [{"t": 2.0, "kind": "drop", "obj": "g"}, {"t": 2.4, "kind": "block_fell", "obj": "g", "on": "table"},
          {"t": 6.0, "kind": "tower_collapsed", "obj": "b"}, {"t": 6.3, "kind": "tower_collapsed", "obj": "g"},
          {"t": 9.0, "kind": "tower_collapsed", "obj": "g"}]
    assert [(f["t"], f["kind"]) for f in failures(gt)] == [(2.0, "drop"), (6.0, "tower_collapsed"),
                                                           (9.0, "tower_collapsed")]


def test_a_collapse_the_falling_block_caused_merges_with_its_drop():
    gt = [{"t": 2.0, "kind": "drop", "obj": "b"}, {"t": 2.3, "kind": "tower_collapsed", "obj": "g"},
          {"t": 2.9, "kind": "block_fell", "obj": "b", "on": "table"},
          {"t": 9.0, "kind": "tower_collapsed", "obj": "g"}]
    fails = failures(gt)
    assert [(f["t"], f["kind"]) for f in fails] == [(2.0, "drop"), (9.0, "tower_collapsed")]
    assert set(fails[0]["objects"]) == {"b", "g"}  # an alarm about the knocked block detects the drop


def test_drops_that_do_not_change_the_outcome_are_not_failures():
    landed = [{"t": 2.0, "kind": "drop", "obj": "b", "target": "g"},
              {"t": 2.5, "kind": "block_fell", "obj": "b", "on": "g", "target": "g", "on_target": True}]
    regrasped = [{"t": 4.0, "kind": "drop", "obj": "g"}, {"t": 4.2, "kind": "regrasped", "obj": "g"}]
    off_target = [{"t": 2.0, "kind": "drop", "obj": "b", "target": "g"},
                  {"t": 2.5, "kind": "block_fell", "obj": "b", "on": "g", "target": "g", "on_target": False}]
    assert failures(landed) == [] and failures(regrasped) == []
    assert [e["t"] for e in benign(landed + regrasped)] == [2.0, 4.0]
    assert [f["kind"] for f in failures(off_target)] == ["drop"]


def test_events_after_the_method_stopped_are_not_held_against_it():
    gt = [{"t": 2.0, "kind": "drop", "obj": "g"}, {"t": 12.0, "kind": "drop", "obj": "b"}]
    assert [f["t"] for f in failures(gt, t_stop=10.0)] == [2.0]
    assert len(failures(gt)) == 2


def test_an_alarm_about_another_object_does_not_detect_a_failure():
    fails = failures([{"t": 2.0, "kind": "drop", "obj": "green_block"}])
    other = [{"t": 2.3, "objects": ["robot", "blue_block"], "constraint_id": "attached_blue_block"}]
    same = [{"t": 2.3, "objects": ["robot", "green_block", "red_block"], "constraint_id": "attached_green_block"}]
    assert match(other, fails)[0] == [None]
    assert match(same, fails)[0] == [pytest.approx(0.3)]
    # records without ``objects``: the object named in the constraint id or the reason
    assert concerns({"constraint_id": "attached_green_block", "reason": ""}, "green_block")
    assert not concerns({"constraint_id": "attached_blue_block", "reason": "blue block dropped"}, "green_block")


def test_gripper_task_disturbances_count_as_failures_and_are_kept_in_records():
    from code_as_monitor.bench.episode import GT_KINDS

    gt = [{"t": 1.0, "kind": "gripper_close", "obj": "pen"}, {"t": 3.0, "kind": "object_moved", "obj": "pen"},
          {"t": 5.0, "kind": "grasp_perturbed", "obj": "book"}, {"t": 8.0, "kind": "object_knocked", "obj": "book"}]
    assert [f["kind"] for f in failures(gt)] == ["object_moved", "grasp_perturbed", "object_knocked"]
    assert set(FAILURE_KINDS) <= set(GT_KINDS)


def test_matching_window_and_latency():
    fails = [{"t": 2.0, "kind": "drop", "obj": "g"}, {"t": 20.0, "kind": "drop", "obj": "g"}]
    alarms = [{"t": 2.6, "objects": ["g"]}, {"t": 3.0, "objects": ["g"]}, {"t": 40.0, "objects": ["g"]}]
    lat, used = match(alarms, fails)
    assert lat == [pytest.approx(0.6), None]
    assert used == [True, False, False]


def test_detection_recall_false_alarms_and_proactive_precision():
    drop = {"t": 2.0, "kind": "drop", "obj": "g"}
    recs = [
        _rec(0, True, alarms=[{"t": 2.5, "proactive": False, "objects": ["g"]}], gt=[drop]),  # detected, 0.5 s
        _rec(0, False, alarms=[], gt=[drop], episode=1),  # missed
        _rec(0, True, episode=2, alarms=[
            {"t": 5.0, "proactive": True, "cf": {"confirmed": True, "lead_s": 1.5}},  # confirmed prediction
            {"t": 7.0, "proactive": True, "cf": {"confirmed": False, "lead_s": None}},  # unconfirmed -> false
            {"t": 8.0, "proactive": False},  # nothing happened -> false
        ]),
    ]
    d = detection(recs)
    assert (d["failures"], d["detected"]) == (2, 1) and d["recall"] == pytest.approx(0.5)
    assert d["latencies"] == [pytest.approx(0.5)]
    assert d["unmatched_per_ep"] == pytest.approx(2 / 3)
    assert (d["proactive_alarms"], d["proactive_confirmed"]) == (2, 1)
    assert d["proactive_precision"] == pytest.approx(0.5) and d["lead_median"] == pytest.approx(1.5)


def test_a_reactive_alarm_a_rollout_confirms_is_not_false_and_not_a_proactive_figure():
    """A reactive alarm whose halt came before any failure was logged gets a rollout (``bench.episode``): confirmed,
    it is no false alarm; unconfirmed, it is one; neither enters proactive precision."""
    recs = [_rec(0, False, alarms=[
        {"t": 8.1, "proactive": False, "objects": ["block"], "cf": {"confirmed": True, "lead_s": 1.2}},
        {"t": 9.0, "proactive": False, "objects": ["stick"], "cf": {"confirmed": False, "lead_s": None}},
        {"t": 9.5, "proactive": True, "objects": ["cube"], "cf": {"confirmed": True, "lead_s": 0.5}},
    ])]
    d = detection(recs)
    assert d["unmatched_per_ep"] == pytest.approx(1.0)  # the unconfirmed reactive one
    assert (d["proactive_alarms"], d["proactive_confirmed"]) == (1, 1) and d["lead_median"] == pytest.approx(0.5)


def test_a_second_alarm_about_a_detected_failure_is_neither_credited_nor_false():
    """Table 2 pour-tea (b): the pot turned in the grasp, "not level" fired, and after the re-plan "not level" fired
    again about the same perturbation (why the pot still read tilted was not determined). Each failure takes one
    alarm; the second concerns the same failure in its window and is not a false alarm; one about another object,
    or past the window, still is."""
    pert = {"t": 3.0, "kind": "grasp_perturbed", "obj": "teapot"}
    recs = [_rec(0, True, gt=[pert], alarms=[
        {"t": 3.4, "proactive": False, "objects": ["teapot", "robot"]},
        {"t": 5.4, "proactive": False, "objects": ["teapot"]},
        {"t": 5.5, "proactive": False, "objects": ["teacup"]},
        {"t": 8.5, "proactive": False, "objects": ["teapot"]},  # past the window: false
    ])]
    d = detection(recs)
    assert (d["failures"], d["detected"], d["repeated_alarms"]) == (1, 1, 1)
    assert d["unmatched_per_ep"] == pytest.approx(2.0)


def test_old_and_new_rules_differ_where_the_issue_says():
    """v1 credited an alarm about another block and counted a drop that landed on its target; v2 does not."""
    recs = [
        _rec(0, True, 10.0, alarms=[{"t": 2.2, "proactive": False, "objects": ["robot", "blue_block"]}],
             gt=[{"t": 2.0, "kind": "drop", "obj": "green_block", "target": "red_block"},
                 {"t": 2.4, "kind": "block_fell", "obj": "green_block", "on": "table", "on_target": False}]),
        _rec(0, True, 10.0, episode=1, alarms=[],
             gt=[{"t": 5.0, "kind": "drop", "obj": "blue_block", "target": "green_block"},
                 {"t": 5.3, "kind": "block_fell", "obj": "blue_block", "on": "green_block", "on_target": True}]),
    ]
    old, new = detection_v1(recs), detection(recs)
    assert (old["failures"], old["detected"]) == (2, 1)
    assert (new["failures"], new["detected"], new["benign_events"]) == (1, 0, 1)


def test_cell_summary_false_alarms_only_for_undisturbed():
    recs = [_rec(0, True, alarms=[{"t": 1.0, "proactive": False}])]
    assert cell_summary(recs, undisturbed=True)["detection"]["false_alarms_per_ep"] == pytest.approx(1.0)
    assert math.isnan(cell_summary(recs, undisturbed=False)["detection"]["false_alarms_per_ep"])
    assert cell_summary(recs)["cost"]["calls"] == 2.0


def test_report_rules_table_puts_old_and_new_side_by_side():
    from code_as_monitor.bench.protocol import CONDITIONS
    from code_as_monitor.bench.report import rules_table

    cond = next(c for c in CONDITIONS if c.id == "stack-p0.3")
    recs = [
        {**_rec(0, True, 10.0, alarms=[{"t": 2.2, "proactive": False, "objects": ["robot", "blue_block"]}],
                gt=[{"t": 2.0, "kind": "drop", "obj": "green_block", "target": "red_block"},
                    {"t": 2.4, "kind": "block_fell", "obj": "green_block", "on": "table", "on_target": False}]),
         "condition": cond.id, "method": "cam"},
    ]
    lines = rules_table({"conditions": [cond], "records": recs}, ["cam"])
    row = next(x for x in lines if x.startswith(f"| {cond.label} |"))
    assert "R 1/1 -> 0/1" in row and "FA 0.00 -> 1.00" in row
    assert rules_table({"conditions": [cond], "records": recs}, []) == []


BLOCKS = [f"block_{i:02d}" for i in range(40)]


def _sweep_gt(final: int) -> list[dict]:
    """A sweep episode: 25 blocks inside at 5.2 s (band 16..24, over-swept), ``final`` inside at the end."""
    inside = BLOCKS[:25]
    return [{"t": 5.0, "kind": "zone_count", "obj": "zone", "count": 23},
            {"t": 5.2, "kind": "zone_count", "obj": "zone", "count": 25},
            {"t": 5.2, "kind": "over_swept", "obj": "zone", "count": 25, "band": [16, 24],
             "objects": ["zone", *inside]},
            {"t": 9.0, "kind": "zone_count", "obj": "zone", "count": final}]


def test_an_alarm_about_the_zone_detects_the_over_sweep_and_one_about_another_object_does_not():
    capped = {"t": 5.3, "proactive": False, "constraint_id": "capped_in_zone", "objects": [*BLOCKS, "zone"],
              "reason": "25 blocks are inside the zone, more than 24"}
    unrelated = {"t": 5.3, "proactive": False, "constraint_id": "attached_block_39", "objects": ["robot", "block_39"]}
    fails = failures(_sweep_gt(final=26))
    assert [(f["kind"], f["t"]) for f in fails] == [("over_swept", 5.2)]
    assert match([capped], fails)[0] == [pytest.approx(0.1)]
    assert match([unrelated], fails) == ([None], [False])  # block_39 is not in the zone: not this failure
    # in a record: the capped alarm is a detection, not a false alarm; v1 (first round) had no sweep failure
    new = detection([_rec(0, False, 5.3, alarms=[capped], gt=_sweep_gt(final=26))])
    old = detection_v1([_rec(0, False, 5.3, alarms=[capped], gt=_sweep_gt(final=26))])
    assert (new["failures"], new["detected"], new["unmatched_per_ep"]) == (1, 1, 0.0)
    assert (old["failures"], old["unmatched_per_ep"]) == (0, 1.0)
    other = detection([_rec(0, False, 5.3, alarms=[unrelated], gt=_sweep_gt(final=26))])
    assert (other["failures"], other["detected"], other["unmatched_per_ep"]) == (1, 0, 1.0)


def test_an_over_sweep_the_zone_recovers_from_is_benign_and_one_after_the_stop_is_not_counted():
    gt = _sweep_gt(final=22)  # further strokes shoved blocks out of the far side: the episode ends in band
    assert failures(gt) == [] and [e["kind"] for e in benign(gt)] == ["over_swept"]
    capped = {"t": 5.3, "proactive": False, "objects": [*BLOCKS, "zone"]}
    d = detection([_rec(0, True, 30.0, alarms=[capped], gt=gt)])
    assert (d["failures"], d["benign_events"], d["unmatched_per_ep"]) == (0, 1, 0.0)
    assert failures(_sweep_gt(final=26), t_stop=5.1) == []  # blocks in flight after the halt


def test_a_misplacement_is_a_failure_of_its_own_unless_a_disturbance_of_that_action_caused_it():
    pert = {"t": 4.75, "kind": "grasp_perturbed", "obj": "book"}
    own = {"t": 7.25, "kind": "misplaced", "obj": "book", "target": "bookshelf"}
    caused = {**own, "after": {"t": 4.75, "kind": "grasp_perturbed", "obj": "book"}}
    assert [f["kind"] for f in failures([pert, own])] == ["grasp_perturbed", "misplaced"]
    (f,) = failures([pert, caused])
    assert f["kind"] == "grasp_perturbed" and f["objects"] == ["book", "book"]
    # a cause that is not a failure (here: after the stop) leaves the misplacement standing on its own
    orphan = {**own, "after": {"t": 4.75, "kind": "object_moved", "obj": "bookshelf"}}
    assert [f["kind"] for f in failures([orphan])] == ["misplaced"]
    # "book dropped" after the release detects it; the first round's rules did not count it
    dropped = {"t": 7.5, "proactive": False, "objects": ["book", "bookshelf", "robot"]}
    new = detection([_rec(0, True, 20.0, alarms=[dropped], gt=[own])])
    old = detection_v1([_rec(0, True, 20.0, alarms=[dropped], gt=[own])])
    assert (new["failures"], new["detected"], new["unmatched_per_ep"]) == (1, 1, 0.0)
    assert (old["failures"], old["unmatched_per_ep"]) == (0, 1.0)
