"""The RLBench protocol: a flagged episode is abandoned and a new one started, until each cell has its valid ones.

The paper (supplementary, "RLBench"): "any episode flagged as a failure by the detection framework is deemed
invalid, and a new episode is initiated"; the success rate is over valid episodes. Here an *attempt* is one
episode key (condition, method, seed index, attempt index) run with ``max_replans`` 0, so a method that raises
an alarm (CaM's violated check or reactive failure, DoReMi's "no") stops the episode at once: the attempt is
*flagged* (:func:`flagged`, ``replans`` > 0). Attempt ``a`` of every method uses the same episode seed
(``protocol.episode_seed``): the same scene and the same draws of the policy's action noise, so the methods meet
the same mistakes. The *valid* episodes of a cell are its first ``n`` unflagged attempts in attempt order; the
open loop flags nothing, so its valid episodes are attempts ``0 .. n-1``.

:func:`run_restart_bench` runs rounds of :func:`~code_as_monitor.bench.runner.run_bench` (resumable: finished
attempts are skipped), each round adding attempts to the cells that have fewer than ``n`` valid episodes, up to
``max_attempts`` attempts per cell. :func:`restart_summary` gives per cell: success over the valid episodes,
attempts and restarts used, sim and wall time spent per valid episode (flagged attempts included: the cost of a
restart), and the detection metrics (``bench.metrics.detection``) over every attempt used.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

from code_as_monitor.bench.metrics import detection, mean_ci
from code_as_monitor.bench.protocol import BenchSpec
from code_as_monitor.core.errors import ConfigError

CellKey = tuple[str, str, int]
"""(condition, method, seed index)."""


def flagged(rec: dict[str, Any]) -> bool:
    """Did the method flag this attempt (a failed subgoal: an alarm, a reactive failure, or a monitor that could
    not be set up)? An errored record is not an attempt at all (it is run again on resume)."""
    return int(rec.get("replans") or 0) > 0 or bool(rec.get("alarms"))


def attempts_by_cell(records: list[dict[str, Any]]) -> dict[CellKey, list[dict[str, Any]]]:
    """Records without an error, grouped by cell and sorted by attempt index."""
    out: dict[CellKey, list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        if not r.get("error"):
            out[(r["condition"], r["method"], int(r["seed"]))].append(r)
    for v in out.values():
        v.sort(key=lambda r: int(r["episode"]))
    return dict(out)


def used_attempts(attempts: list[dict[str, Any]], n_valid: int) -> list[dict[str, Any]]:
    """The attempts up to and including the ``n_valid``-th unflagged one (all of them if there are fewer);
    attempts must be consecutive from index 0 (a gap, an attempt not yet run or errored, ends the list)."""
    out, valid = [], 0
    for i, r in enumerate(attempts):
        if int(r["episode"]) != i or valid >= n_valid:
            break
        out.append(r)
        valid += not flagged(r)
    return out


def restart_summary(records: list[dict[str, Any]], n_valid: int) -> dict[CellKey, dict[str, Any]]:
    """Per cell: ``valid`` (n), ``success`` (mean % and 95 % t half-width over the valid episodes), ``attempts``,
    ``restarts`` (flagged attempts among them), ``sim_s_per_valid`` and ``wall_s_per_valid`` (all attempts' time
    over the valid episodes), ``complete`` (``n_valid`` reached), and ``detection`` over the attempts used."""
    out = {}
    for key, atts in attempts_by_cell(records).items():
        used = used_attempts(atts, n_valid)
        valid = [r for r in used if not flagged(r)]
        mean, hw = mean_ci([100.0 * bool(r.get("success")) for r in valid])
        n = len(valid)
        out[key] = {
            "valid": n, "attempts": len(used), "restarts": len(used) - n, "complete": n >= n_valid,
            "success": {"mean": mean, "ci": hw, "n": n, "ci_over": "episodes"},
            "sim_s_per_valid": sum(float(r.get("sim_time_s") or 0.0) for r in used) / n if n else math.nan,
            "wall_s_per_valid": sum(float(r.get("wall_time_s") or 0.0) for r in used) / n if n else math.nan,
            "detection": detection(used),
        }
    return out


def pending_attempts(records: list[dict[str, Any]], cells: list[CellKey], n_valid: int, max_attempts: int) -> dict[
        CellKey, int]:
    """How many attempts each cell should have after the next round: enough for the valid episodes still missing
    if the cell's flag rate so far holds (at least one more), never more than ``max_attempts``. Cells that are
    complete or at the bound are left out."""
    by = attempts_by_cell(records)
    out = {}
    for key in cells:
        atts = by.get(key, [])
        used = used_attempts(atts, n_valid)
        n_ok = sum(not flagged(r) for r in used)
        if n_ok >= n_valid or len(used) >= max_attempts:
            continue
        if len(used) < len(atts) or not used:  # a gap (an attempt to redo) or nothing yet: fill up to n_valid
            want = max(n_valid, len(used) + 1)
        else:
            rate = n_ok / len(used)  # valid per attempt so far
            missing = n_valid - n_ok
            want = len(used) + (missing if rate <= 0 else max(1, math.ceil(missing / max(rate, 0.25))))
        out[key] = min(max_attempts, want)
    return out


def run_restart_bench(spec: BenchSpec, results: str | Path, n_valid: int, max_attempts: int,
                      run_round: Callable[[BenchSpec], Any], read: Callable[[], list[dict[str, Any]]],
                      max_rounds: int = 20) -> dict[str, Any]:
    """Run rounds until every cell of ``spec`` has ``n_valid`` valid episodes or ``max_attempts`` attempts.

    Args:
        spec: methods, conditions, seeds and options (its ``episodes`` is ignored: attempts are decided here).
        results: the results file (for messages).
        run_round: runs one :class:`BenchSpec` (``runner.run_bench`` bound to the file, executor and callbacks).
        read: the file's current episode records.
    Returns ``{"rounds": r, "incomplete": [cells short of n_valid at the bound]}``.
    """
    if n_valid < 1 or max_attempts < n_valid:
        raise ConfigError(f"restart protocol: need 1 <= valid episodes ({n_valid}) <= max attempts ({max_attempts})")
    cells = [(c, m, s) for c in spec.conditions for m in spec.methods for s in range(spec.seeds)]
    rounds = 0
    for rounds in range(1, max_rounds + 1):
        todo = pending_attempts(read(), cells, n_valid, max_attempts)
        if not todo:
            rounds -= 1
            break
        # one run per (method, attempts wanted): a BenchSpec is a product of conditions x methods x seeds
        groups: dict[tuple[str, int, int], list[str]] = defaultdict(list)
        for (c, m, s), want in todo.items():
            groups[(m, s, want)].append(c)
        for (m, s, want), conds in sorted(groups.items()):
            run_round(BenchSpec(methods=[m], conditions=sorted(set(conds)), seeds=s + 1, episodes=want,
                                options=spec.options))
    incomplete = [key for key, summ in restart_summary(read(), n_valid).items()
                  if key in cells and not summ["complete"]]
    return {"rounds": rounds, "incomplete": sorted(incomplete), "results": str(results)}


__all__ = ["attempts_by_cell", "flagged", "pending_attempts", "restart_summary", "run_restart_bench",
           "used_attempts"]
