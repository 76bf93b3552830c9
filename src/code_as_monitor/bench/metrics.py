"""Benchmark metrics: success and time with 95 % confidence intervals, VLM cost, failure detection.

Confidence intervals (:func:`mean_ci`): as in the paper, a cell's value is the mean over seeds of the
per-seed means (success rate = the fraction of a seed's episodes that succeeded); the 95 % interval
is ``mean +- t(0.975, n - 1) * sd / sqrt(n)`` over the n per-seed means (sample sd, ddof = 1). With
a single seed (the quick protocol) the interval is taken over episodes instead (n = episodes), and
the cell says so (``ci_over``). n = 1: no interval (NaN). Execution time is the sim time at which
the method stopped (before the settle time), over all episodes, successful or not; VLM computation
time is excluded, as in the paper's CLIPort protocol.

Detection against the simulator's ground-truth event log (:func:`detection`). A detector is judged on
the failures that matter: what would change the episode's outcome if nothing were done about it.

- **Failures** (:func:`failures`) are ground-truth events of the kinds in :data:`FAILURE_KINDS`: ``drop``
  (the suction let an object go), ``tower_collapsed`` (a stacked block fell off) and the gripper tasks'
  one-shot disturbances (:mod:`code_as_monitor.sim.triggered`: ``object_moved``, ``grasp_perturbed``,
  ``object_knocked``, ``grasp_slipped``, ``pour_undone``), the RLBench-style tasks' ``policy_failure`` (the
  noisy policy's own first failed skill; its ``objects`` are the objects that skill acted on), the sweep's
  ``over_swept`` (the zone first held more blocks than the task's success band accepts; its ``objects`` are
  the zone and the blocks inside then, :mod:`code_as_monitor.sim.tasks.sweep_half`) and the gripper tasks'
  ``misplaced`` (a placing skill let its object go and it came to rest out of place by the task's own test:
  a book beside its shelf, or tipped over in it; :mod:`code_as_monitor.sim.placement`), except:

  * a drop that does not change the outcome: the object came to rest on the target it was being carried to,
    within the task's placement tolerance (``block_fell.on_target``), or the suction took it again within the
    same action (``regrasped``). Likewise an over-sweep after which the zone's final count (the episode's last
    ``zone_count``) is back inside the event's ``band``: no skill takes blocks out, but further strokes can
    shove blocks out of the far side of a full zone. These are logged, and alarms about them are neither
    credited nor false;
  * consequences, merged with their cause: ``block_fell`` belongs to its drop, and a ``tower_collapsed``
    between a drop and ``MERGE_S`` after the dropped object came to rest is the drop's doing (the falling
    block knocked the tower); collapses within ``MERGE_S`` of each other count once; a ``misplaced`` release whose
    placing action a disturbance of the object or its target interrupted (its ``after``) is that disturbance's
    doing;
  * events after the method stopped (the record's ``sim_time_s``): nothing it could still have detected.

  The rope has no discrete failure event (its failure is not stopping in time); its detection cells stay empty.
- **Matching**: a failure of object ``o`` at time ``t_e`` is *detected* by an alarm raised in
  ``[t_e - EARLY_S, t_e + WINDOW_S]`` (``EARLY_S`` = 0.25 s for the frame clock, ``WINDOW_S`` = 5 s) that
  concerns ``o``: ``o`` owns one of the alarmed constraint's elements (the alarm's ``objects``; records
  written before alarms carried them fall back to ``o`` named in the constraint id or the reason). A merged
  consequence's object counts as the failure's too (an alarm about the knocked tower detects the drop that
  knocked it). Each alarm matches at most one failure (earliest first).
- **Recall** = detected failures / failures, pooled over a cell's episodes.
- **Latency** = first matching alarm time - failure time (seconds; may be slightly negative within
  ``EARLY_S``). Reported as the median and the distribution (plots).
- **False alarms per undisturbed episode**: alarms that detect no failure, concern no benign event, and are
  not confirmed by a counterfactual, per episode of the undisturbed condition. The same count per episode is
  given for every cell (``unmatched_per_ep``). An alarm that another alarm's failure explains (it concerns that
  failure's objects, in its window: a second "not level" about the same perturbation after a re-plan, the state
  it reports still there) is neither credited nor false (``repeated_alarms`` counts them). Rollouts run at
  proactive alarms and at reactive ones that no logged failure of their objects explains when they fire
  (``bench.episode.unexplained``: the halt may come before a skill's own judgement would have logged the
  failure); records written before that have rollouts at proactive alarms only.
- **Proactive precision**: among proactive alarms (only those) that got a counterfactual rollout
  (``bench.counterfactual``: save the world at the alarm, continue the open-loop plan without the monitor and
  without new disturbances, restore), the fraction after which the continuation ended with the task failed: one
  rule for every task. **Lead time** = the rollout's first failure event (or the failed plan's end) - the alarm time
  (median over confirmed ones). Precision only: a rollout cannot tell what a method failed to predict.

:func:`detection_v1` keeps the first round's definitions (every drop and collapse a failure, no sweep failure,
any alarm in the window matches, events after the stop counted) so reports can show old and new figures side by
side.

Open-loop raises no alarm; its detection cells are empty, not zero.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

import numpy as np

FAILURE_KINDS = ("drop", "tower_collapsed", "object_moved", "grasp_perturbed", "object_knocked", "grasp_slipped",
                 "pour_undone", "policy_failure", "over_swept", "misplaced")
V1_KINDS = tuple(k for k in FAILURE_KINDS if k not in ("over_swept", "misplaced"))
"""The failure kinds of :func:`detection_v1` (the over-sweep and misplacement events came later; the first round
had neither)."""
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


def _by_time(gt: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(gt, key=lambda e: e["t"])


def _drop_resolution(gt: list[dict[str, Any]], drop: dict[str, Any]) -> dict[str, Any] | None:
    """The event that settled ``drop``: its ``regrasped`` or ``block_fell`` (None if neither was logged)."""
    for e in _by_time(gt):
        if e["t"] >= drop["t"] and e.get("obj") == drop.get("obj") and e["kind"] in ("regrasped", "block_fell"):
            return e
    return None


def _harmless(gt: list[dict[str, Any]], e: dict[str, Any]) -> bool:
    """Did event ``e`` (a failure kind) leave the outcome unchanged? A drop that landed on its target or was
    regrasped; an over-sweep whose zone ends back in its ``band`` (the episode's last ``zone_count``)."""
    if e["kind"] == "drop":
        res = _drop_resolution(gt, e)
        return res is not None and (res["kind"] == "regrasped" or bool(res.get("on_target")))
    if e["kind"] == "over_swept" and e.get("band") is not None:
        final = next((z for z in reversed(_by_time(gt)) if z["kind"] == "zone_count" and z.get("obj") == e.get("obj")),
                     None)
        lo, hi = e["band"]
        return final is not None and final["t"] >= e["t"] and lo <= final["count"] <= hi
    return False


def failures(gt: list[dict[str, Any]], t_stop: float | None = None) -> list[dict[str, Any]]:
    """The failures of one episode that matter (see the module docstring), each with ``objects``: its own
    object plus those of the consequences merged into it.

    Args:
        gt: the episode's ground-truth events (``t``, ``kind``, ``obj`` and kind-specific keys).
        t_stop: sim time at which the method stopped; later events are not counted (None: all).
    """
    out: list[dict[str, Any]] = []
    windows: list[tuple[float, float, dict[str, Any]]] = []  # (from, to, failure) a collapse merges into
    for e in _by_time(gt):
        if e["kind"] not in FAILURE_KINDS or (t_stop is not None and e["t"] > t_stop + 1e-9):
            continue
        f = {**e, "objects": list(e.get("objects") or [e.get("obj", "")])}
        if _harmless(gt, e):
            continue
        if e["kind"] == "drop":
            res = _drop_resolution(gt, e)
            end = (res["t"] if res is not None else e["t"]) + MERGE_S
            windows.append((e["t"], end, f))
        elif e["kind"] == "misplaced" and e.get("after"):
            c = e["after"]
            cause = next((x for x in out if x["t"] == c.get("t") and x["kind"] == c.get("kind")
                          and x.get("obj") == c.get("obj")), None)
            if cause is not None:  # the disturbance during the placing action put it out of place
                cause["objects"].append(e.get("obj", ""))
                continue
        elif e["kind"] == "tower_collapsed":
            cause = next((w for lo, hi, w in windows if lo <= e["t"] <= hi), None)
            if cause is not None:
                cause["objects"].append(e.get("obj", ""))
                continue
            windows.append((e["t"], e["t"] + MERGE_S, f))
        out.append(f)
    return out


def benign(gt: list[dict[str, Any]], t_stop: float | None = None) -> list[dict[str, Any]]:
    """Failure-kind events that did not change the outcome (a drop that landed on its target or was regrasped in
    the same action; an over-sweep whose zone ended back in band)."""
    return [e for e in _by_time(gt) if e["kind"] in FAILURE_KINDS and (t_stop is None or e["t"] <= t_stop + 1e-9)
            and _harmless(gt, e)]


def concerns(alarm: dict[str, Any], obj: str) -> bool:
    """Does ``alarm`` concern object ``obj``? By the alarmed constraint's element owners (``objects``), or, for
    records without them, ``obj`` named in the constraint id or the reason."""
    if not obj:
        return False
    objs = alarm.get("objects")
    if objs is not None:
        return obj in objs
    text = f"{alarm.get('constraint_id', '')} {alarm.get('reason', '')}"
    return obj in text or obj.replace("_", " ") in text


def in_window(alarm: dict[str, Any], event: dict[str, Any]) -> bool:
    """Whether ``alarm`` was raised in ``event``'s matching window ``[t - EARLY_S, t + WINDOW_S]``."""
    return event["t"] - EARLY_S <= alarm["t"] <= event["t"] + WINDOW_S


def about(alarm: dict[str, Any], event: dict[str, Any]) -> bool:
    """Whether ``alarm`` is about ``event``: in its window, and concerning one of its ``objects`` (or its ``obj``)."""
    return in_window(alarm, event) and any(concerns(alarm, o) for o in (event.get("objects") or [event.get("obj", "")]))


def match(alarms: list[dict[str, Any]], fails: list[dict[str, Any]],
          same_object: bool = True) -> tuple[list[float | None], list[bool]]:
    """(latency per failure or None, matched flag per alarm), greedy earliest-first; with ``same_object`` an
    alarm matches only a failure it concerns (any of the failure's ``objects``)."""
    used = [False] * len(alarms)
    lat: list[float | None] = []
    order = sorted(range(len(alarms)), key=lambda i: alarms[i]["t"])
    for f in fails:
        hit = None
        for i in order:
            if used[i] or not (about(alarms[i], f) if same_object else in_window(alarms[i], f)):
                continue
            hit = i
            break
        if hit is None:
            lat.append(None)
        else:
            used[hit] = True
            lat.append(round(alarms[hit]["t"] - f["t"], 3))
    return lat, used


def _failures_v1(gt: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for e in _by_time([e for e in gt if e["kind"] in V1_KINDS]):
        if (e["kind"] == "tower_collapsed" and out and out[-1]["kind"] == "tower_collapsed"
                and e["t"] - out[-1]["t"] <= MERGE_S):
            continue
        out.append(e)
    return out


def detection(records: list[dict[str, Any]], rule: str = "v2") -> dict[str, Any]:
    """Detection metrics pooled over ``records`` (one cell); see the module docstring. ``rule="v1"`` applies
    the first round's definitions (for side-by-side comparison only)."""
    if rule not in ("v1", "v2"):
        raise ValueError(f"unknown detection rule {rule!r}; expected 'v1' or 'v2'")
    n_fail = n_det = 0
    latencies: list[float] = []
    unmatched = 0
    pro_n = pro_ok = 0
    leads: list[float] = []
    n_alarms = n_benign = n_again = 0
    for r in records:
        alarms = r.get("alarms") or []
        gt = r.get("gt") or []
        n_alarms += len(alarms)
        if rule == "v1":
            fails, harmless = _failures_v1(gt), []
        else:
            t_stop = r.get("sim_time_s")
            fails, harmless = failures(gt, t_stop), benign(gt, t_stop)
        n_benign += len(harmless)
        lat, used = match(alarms, fails, same_object=rule == "v2")
        n_fail += len(lat)
        n_det += sum(x is not None for x in lat)
        latencies += [x for x in lat if x is not None]
        for a, u in zip(alarms, used):
            cf = a.get("cf")
            if cf is not None and a.get("proactive"):
                pro_n += 1
                if cf.get("confirmed"):
                    pro_ok += 1
                    if cf.get("lead_s") is not None:
                        leads.append(float(cf["lead_s"]))
            about_benign = any(about(a, b) for b in harmless)
            again = rule == "v2" and not u and any(about(a, f) for f in fails)  # a failure another alarm took
            if again:
                n_again += 1
            if not u and not (cf and cf.get("confirmed")) and not about_benign and not again:
                unmatched += 1
    n = len(records)
    return {
        "rule": rule,
        "episodes": n,
        "alarms": n_alarms,
        "failures": n_fail,
        "benign_events": n_benign,
        "detected": n_det,
        "recall": n_det / n_fail if n_fail else float("nan"),
        "latencies": latencies,
        "latency_median": float(np.median(latencies)) if latencies else float("nan"),
        "unmatched_per_ep": unmatched / n if n else float("nan"),
        "repeated_alarms": n_again,
        "proactive_alarms": pro_n,
        "proactive_confirmed": pro_ok,
        "proactive_precision": pro_ok / pro_n if pro_n else float("nan"),
        "lead_median": float(np.median(leads)) if leads else float("nan"),
        "leads": leads,
    }


def detection_v1(records: list[dict[str, Any]]) -> dict[str, Any]:
    """:func:`detection` under the first round's definitions (side-by-side comparison only)."""
    return detection(records, rule="v1")


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


__all__ = ["EARLY_S", "FAILURE_KINDS", "MERGE_S", "V1_KINDS", "WINDOW_S", "benign", "cell_summary", "concerns", "cost",
           "detection", "detection_v1", "failures", "match", "mean_ci", "seed_level", "t_quantile"]
