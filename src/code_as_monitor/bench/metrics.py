"""Benchmark metrics: success and time with 95 % confidence intervals, VLM cost, failure detection.

Confidence intervals (:func:`mean_ci`): as in the paper, a cell's value is the mean over seeds of the
per-seed means (success rate = the fraction of a seed's episodes that succeeded); the 95 % interval
is ``mean +- t(0.975, n - 1) * sd / sqrt(n)`` over the n per-seed means (sample sd, ddof = 1). With
a single seed (the quick protocol) the interval is taken over episodes instead (n = episodes), and
the cell says so (``ci_over``). n = 1: no interval (NaN). Execution time is the sim time at which
the method stopped (before the settle time), over all episodes, successful or not; VLM computation
time is excluded, as in the paper's CLIPort protocol.

Detection against the simulator's ground-truth event log (:func:`detection`):

- **Real failures** are ground-truth events of kind ``drop`` (the suction or the gripper let an object
  go) and ``tower_collapsed`` (a stacked block fell off), and the gripper tasks' one-shot disturbances
  (:mod:`code_as_monitor.sim.triggered`): ``object_moved`` (a pen or book moved under the gripper, a
  holder moved during insertion), ``grasp_perturbed`` (the held object turned in the grasp),
  ``object_knocked`` (a placed object knocked over), ``grasp_slipped`` (the grasp slipped off a handle)
  and ``pour_undone`` (a pouring pot back to level). ``block_fell`` is the consequence of a drop and is
  not counted again; collapse events of several blocks within ``MERGE_S`` (1 s) count once. Sweep
  and rope have no discrete failure events (their failure is not stopping in time); their
  detection cells stay empty.
- **Matching**: a failure at time ``t_e`` is *detected* when an alarm is raised in
  ``[t_e - EARLY_S, t_e + WINDOW_S]`` (``EARLY_S`` = 0.25 s for the frame clock, ``WINDOW_S`` = 5 s).
  Each alarm matches at most one failure (earliest first).
- **Recall** = detected failures / real failures, pooled over a cell's episodes.
- **Latency** = first matching alarm time - failure time (seconds; may be slightly negative within
  ``EARLY_S``). Reported as the median and the distribution (plots).
- **False alarms per undisturbed episode**: alarms that match no failure and are not confirmed by a
  counterfactual, per episode of the undisturbed condition (``stack-p0``). The same count per
  episode is also given for every cell (``unmatched_per_ep``).
- **Proactive precision**: among proactive alarms that got a counterfactual rollout (see
  ``bench.counterfactual``: save the world at the alarm, continue the open-loop plan without the
  monitor for ``horizon_s``, restore), the fraction whose predicted failure happened in the rollout:
  a ``tower_collapsed`` event for the CLIPort tasks; for the gripper tasks, the plan ending with the
  task failed. **Lead time** = predicted event time (or the failed plan's end) in the rollout - alarm
  time (median over confirmed ones). Precision only: a rollout cannot tell what a method failed to
  predict.

Open-loop raises no alarm; its detection cells are empty, not zero.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

import numpy as np

FAILURE_KINDS = ("drop", "tower_collapsed", "object_moved", "grasp_perturbed", "object_knocked", "grasp_slipped",
                 "pour_undone")
EARLY_S = 0.25
WINDOW_S = 5.0
MERGE_S = 1.0


def t_quantile(n: int, level: float = 0.95) -> float:
    """Two-sided Student-t quantile for ``n`` samples (``n - 1`` degrees of freedom)."""
    from scipy.stats import t

    return float(t.ppf(0.5 + level / 2.0, n - 1))


def mean_ci(values: list[float], level: float = 0.95) -> tuple[float, float]:
    """(mean, half-width of the ``level`` t-interval); half-width NaN for fewer than 2 values."""
    v = np.asarray([x for x in values if x is not None and not math.isnan(x)], dtype=float)
    if v.size == 0:
        return float("nan"), float("nan")
    if v.size == 1:
        return float(v[0]), float("nan")
    return float(v.mean()), t_quantile(v.size, level) * float(v.std(ddof=1)) / math.sqrt(v.size)


def seed_level(records: list[dict[str, Any]], value: str) -> dict[str, Any]:
    """Mean and 95 % CI of ``value(record)`` over seeds (per-seed means), or over episodes with one seed."""
    get = _getter(value)
    by_seed: dict[int, list[float]] = defaultdict(list)
    for r in records:
        x = get(r)
        if x is not None:
            by_seed[int(r["seed"])].append(float(x))
    if len(by_seed) >= 2:
        mean, hw = mean_ci([float(np.mean(v)) for v in by_seed.values()])
        over, n = "seeds", len(by_seed)
    else:
        vals = [x for v in by_seed.values() for x in v]
        mean, hw = mean_ci(vals)
        over, n = "episodes", len(vals)
    return {"mean": mean, "ci": hw, "n": n, "ci_over": over}


def _getter(value: str):
    if value == "success":
        return lambda r: 100.0 * bool(r.get("success"))
    if value == "sim_time_s":
        return lambda r: r.get("sim_time_s")
    raise KeyError(value)


def failures(gt: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Real failure events of one episode (see the module docstring), merged."""
    out: list[dict[str, Any]] = []
    for e in sorted((e for e in gt if e["kind"] in FAILURE_KINDS), key=lambda e: e["t"]):
        if (e["kind"] == "tower_collapsed" and out and out[-1]["kind"] == "tower_collapsed"
                and e["t"] - out[-1]["t"] <= MERGE_S):
            continue
        out.append(e)
    return out


def match(alarms: list[dict[str, Any]], fails: list[dict[str, Any]]) -> tuple[list[float | None], list[bool]]:
    """(latency per failure or None, matched flag per alarm), greedy earliest-first."""
    used = [False] * len(alarms)
    lat: list[float | None] = []
    order = sorted(range(len(alarms)), key=lambda i: alarms[i]["t"])
    for f in fails:
        hit = None
        for i in order:
            if not used[i] and f["t"] - EARLY_S <= alarms[i]["t"] <= f["t"] + WINDOW_S:
                hit = i
                break
        if hit is None:
            lat.append(None)
        else:
            used[hit] = True
            lat.append(round(alarms[hit]["t"] - f["t"], 3))
    return lat, used


def detection(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Detection metrics pooled over ``records`` (one cell); see the module docstring."""
    n_fail = n_det = 0
    latencies: list[float] = []
    unmatched = 0
    pro_n = pro_ok = 0
    leads: list[float] = []
    n_alarms = 0
    for r in records:
        alarms = r.get("alarms") or []
        n_alarms += len(alarms)
        lat, used = match(alarms, failures(r.get("gt") or []))
        n_fail += len(lat)
        n_det += sum(x is not None for x in lat)
        latencies += [x for x in lat if x is not None]
        for a, u in zip(alarms, used):
            cf = a.get("cf")
            if cf is not None:
                pro_n += 1
                if cf.get("confirmed"):
                    pro_ok += 1
                    if cf.get("lead_s") is not None:
                        leads.append(float(cf["lead_s"]))
            if not u and not (cf and cf.get("confirmed")):
                unmatched += 1
    n = len(records)
    return {
        "episodes": n,
        "alarms": n_alarms,
        "failures": n_fail,
        "detected": n_det,
        "recall": n_det / n_fail if n_fail else float("nan"),
        "latencies": latencies,
        "latency_median": float(np.median(latencies)) if latencies else float("nan"),
        "unmatched_per_ep": unmatched / n if n else float("nan"),
        "proactive_alarms": pro_n,
        "proactive_confirmed": pro_ok,
        "proactive_precision": pro_ok / pro_n if pro_n else float("nan"),
        "lead_median": float(np.median(leads)) if leads else float("nan"),
        "leads": leads,
    }


def cost(records: list[dict[str, Any]]) -> dict[str, float]:
    """Mean VLM calls and tokens per episode, and mean wall seconds per episode."""
    if not records:
        return {"calls": float("nan"), "tokens": float("nan"), "wall_s": float("nan")}
    return {
        "calls": float(np.mean([r["vlm"]["calls"] for r in records])),
        "tokens": float(np.mean([r["vlm"]["total_tokens"] for r in records])),
        "wall_s": float(np.mean([r.get("wall_time_s") or 0.0 for r in records])),
    }


def cell_summary(records: list[dict[str, Any]], undisturbed: bool = False) -> dict[str, Any]:
    """Everything the report shows for one (condition, method) cell."""
    det = detection(records)
    det["false_alarms_per_ep"] = det["unmatched_per_ep"] if undisturbed else float("nan")
    return {
        "n": len(records),
        "errors": sum(1 for r in records if r.get("error")),
        "success": seed_level(records, "success"),
        "time": seed_level(records, "sim_time_s"),
        "cost": cost(records),
        "detection": det,
    }


__all__ = ["EARLY_S", "FAILURE_KINDS", "MERGE_S", "WINDOW_S", "cell_summary", "cost", "detection", "failures",
           "match", "mean_ci", "seed_level", "t_quantile"]
