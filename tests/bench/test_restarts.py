"""The RLBench restart protocol on constructed records: flags, valid episodes, restarts and time, the rounds."""

from __future__ import annotations

import math

import pytest

from code_as_monitor.bench.protocol import SUITES, BenchSpec, condition
from code_as_monitor.bench.report_rlbench import n_valid_of, rlbench_markdown
from code_as_monitor.bench.restarts import (
    flagged,
    pending_attempts,
    restart_summary,
    run_restart_bench,
    used_attempts,
)
from code_as_monitor.core.errors import ConfigError


def rec(ep: int, method: str = "cam", cond: str = "rlb-turn-tap", flag: bool = False, ok: bool = True,
        t: float = 10.0, gt: list | None = None, alarm_t: float | None = None) -> dict:
    alarms = [] if not flag else [{"t": alarm_t if alarm_t is not None else 3.0, "constraint_id": "c", "phase":
                                   "upon", "proactive": False, "reason": "tap not turned", "objects": ["tap"]}]
    return {"condition": cond, "method": method, "seed": 0, "episode": ep, "success": ok, "replans": int(flag),
            "alarms": alarms, "sim_time_s": t, "wall_time_s": 2 * t, "gt": gt or [], "error": None}


def test_rlbench_suite_has_the_six_tasks_undisturbed() -> None:
    assert len(SUITES["rlbench"]) == 6
    for cid in SUITES["rlbench"]:
        assert condition(cid).undisturbed and condition(cid).suite == "rlbench"


def test_flags_and_the_valid_episodes() -> None:
    assert flagged(rec(0, flag=True)) and not flagged(rec(0)) and flagged({**rec(0), "replans": 1, "alarms": []})
    atts = [rec(0, flag=True, ok=False), rec(1), rec(2, flag=True), rec(3), rec(4)]
    assert [r["episode"] for r in used_attempts(atts, 2)] == [0, 1, 2, 3]
    assert [r["episode"] for r in used_attempts(atts, 9)] == [0, 1, 2, 3, 4]
    assert [r["episode"] for r in used_attempts([rec(0), rec(2)], 3)] == [0]  # a gap ends the list


def test_summary_success_over_valid_restarts_and_time() -> None:
    gt = [{"t": 2.9, "kind": "policy_failure", "obj": "tap", "objects": ["tap"], "what": "grasp_missed"}]
    records = [rec(0, flag=True, ok=False, gt=gt), rec(1, ok=True), rec(2, ok=False, t=20.0), rec(3, flag=True),
               rec(4, ok=True), rec(5, ok=True)]
    k = restart_summary(records, 3)[("rlb-turn-tap", "cam", 0)]
    assert k["valid"] == 3 and k["attempts"] == 5 and k["restarts"] == 2 and k["complete"]
    assert k["success"]["mean"] == pytest.approx(200 / 3)
    assert k["sim_s_per_valid"] == pytest.approx((10 + 10 + 20 + 10 + 10) / 3)
    d = k["detection"]
    assert (d["failures"], d["detected"], d["alarms"]) == (1, 1, 2)  # one true flag, one false
    assert d["unmatched_per_ep"] * d["episodes"] == pytest.approx(1)
    short = restart_summary(records[:2], 3)[("rlb-turn-tap", "cam", 0)]
    assert not short["complete"] and short["valid"] == 1
    assert math.isnan(restart_summary([rec(0, flag=True)], 1)[("rlb-turn-tap", "cam", 0)]["sim_s_per_valid"])


def test_pending_attempts_extend_by_the_flag_rate_within_the_bound() -> None:
    cell = ("rlb-turn-tap", "cam", 0)
    assert pending_attempts([], [cell], 4, 12) == {cell: 4}
    half = [rec(i, flag=i % 2 == 0) for i in range(4)]  # 2 valid of 4
    assert pending_attempts(half, [cell], 4, 12) == {cell: 8}  # 2 missing at 1 valid per 2 attempts
    assert pending_attempts(half, [cell], 4, 6) == {cell: 6}
    assert pending_attempts([rec(i) for i in range(4)], [cell], 4, 12) == {}
    assert pending_attempts([rec(i, flag=True) for i in range(12)], [cell], 4, 12) == {}  # at the bound


def test_rounds_run_until_every_cell_has_its_valid_episodes() -> None:
    store: dict = {}

    def run_round(spec: BenchSpec) -> None:  # cam flags every third attempt, doremi every attempt
        for c in spec.conditions:
            for m in spec.methods:
                for e in range(spec.episodes):
                    store.setdefault((c, m, e), rec(e, m, c, flag=(m == "doremi") or (m == "cam" and e % 3 == 0)))

    spec = BenchSpec(methods=["open-loop", "cam", "doremi"], conditions=["rlb-turn-tap", "rlb-screw-bulb"], seeds=1,
                     episodes=1, options={"max_replans": 0})
    out = run_restart_bench(spec, "x.jsonl", 5, 15, run_round, lambda: list(store.values()))
    summ = restart_summary(list(store.values()), 5)
    for c in spec.conditions:
        assert summ[(c, "open-loop", 0)]["attempts"] == 5
        assert summ[(c, "cam", 0)]["valid"] == 5 and summ[(c, "cam", 0)]["restarts"] == 3  # attempts 0, 3, 6
        assert summ[(c, "doremi", 0)]["attempts"] == 15 and not summ[(c, "doremi", 0)]["complete"]
    assert sorted(out["incomplete"]) == [("rlb-screw-bulb", "doremi", 0), ("rlb-turn-tap", "doremi", 0)]
    md = rlbench_markdown(list(store.values()))
    assert n_valid_of(list(store.values()))[0] == 5
    assert "Turn tap" in md and "ARP +Ours" in md and "(n 5)" in md and "(n 0*)" not in md
    with pytest.raises(ConfigError, match="valid"):
        run_restart_bench(spec, "x", 5, 3, run_round, lambda: [])
