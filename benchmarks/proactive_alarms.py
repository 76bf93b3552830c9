"""Why did a proactive alarm's counterfactual rollout not confirm it? Re-run benchmark episodes and log the state.

For every CaM record of ``RESULTS`` with an unconfirmed proactive alarm (or the records named by ``--key``), the
episode is re-run through the benchmark's episode code (as ``cam reproduce`` does) with three probes:

- at each final check (the upon checks judged when the policy has finished), every non-robot element: the
  centroid the checks read, its horizontal error against its owner's true position, whether the tracker saw it at
  rest, and the support of its measurement from the subgoal start (robot-hidden fraction, weak or not);
- at each proactive alarm: the true horizontal distance between the alarm's two objects (``objects`` of the
  alarm, owner order) and the plan left for the rollout;
- at the rollout's end (before the world is restored): the same true distance, the task's verdict and the
  rollout's ground-truth events.

Prints one block per episode, then the re-run's alarms with their rollout results. Oracle perception and the kb
planner come from the results file's options. Usage::

    nice -n 15 .venv/bin/python benchmarks/proactive_alarms.py results/published/cliport-round3.jsonl \\
        --conditions stack-q1,stack-p0.15
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import code_as_monitor.agent.code_checker as code_checker
import code_as_monitor.bench.counterfactual as counterfactual
import code_as_monitor.bench.episode as episode
from code_as_monitor.bench.commands import parse_key
from code_as_monitor.bench.protocol import Job
from code_as_monitor.bench.reproduce import find_record
from code_as_monitor.bench.runner import episode_records, read_results, record_key


def _xy_distance(world: Any, a: str, b: str) -> float:
    return float(np.linalg.norm(world.position(a)[:2] - world.position(b)[:2]))


def _support(e: Any) -> str:
    s = e.support
    if s is None:
        return "no support"
    return (f"start support {s.points} pts, robot-hidden {s.robot_hidden:.2f}, {'weak' if s.weak() else 'strong'}"
            f"{', carried' if s.carried else ''}")


def _probe_final_check() -> None:
    settle = code_checker.CodeChecker._settle

    def probed(self: Any, obs: Any, ctx: Any) -> Any:
        step = self.runtime.step

        def judged(points: dict[int, np.ndarray], H: Any, ht: Any, t: float) -> Any:
            for e in self._elements:
                name = e.owner[0]
                if name == "robot" or not obs.object_poses or name not in obs.object_poses:
                    continue
                used = np.asarray(points[e.id]).mean(axis=0)
                err = float(np.linalg.norm(used[:2] - obs.object_poses[name][:3, 3][:2]))
                track = H[e.id][:-1] if len(H[e.id]) > 1 else H[e.id]  # the frames before this check
                moved = float(np.linalg.norm(track[-1].mean(axis=0) - track[0].mean(axis=0)))
                print(f"  final check t={t:.3f} {name}: judged at {np.round(used, 4).tolist()}, "
                      f"{err * 100:.2f} cm (xy) off its true centre; "
                      f"{'at rest' if moved <= self.cfg.refresh_motion else 'moved'}; {_support(e)}")
            return step(points, H, ht, t)

        self.runtime.step = judged
        try:
            return settle(self, obs, ctx)
        finally:
            self.runtime.step = step

    code_checker.CodeChecker._settle = probed


_ALARMS: list[dict[str, Any]] = []
"""The re-run's alarm events so far (the last one is the alarm a rollout starts from)."""


def _probe_alarms_and_rollouts() -> None:
    rollout, hook = counterfactual.rollout, episode._Counterfactuals.__call__

    def remember(self: Any, ev: dict[str, Any]) -> None:
        if ev.get("kind") == "alarm":
            _ALARMS.append(ev)
        hook(self, ev)

    def probed(env: Any, horizon_s: float = counterfactual.DEFAULT_HORIZON_S,
               kinds: tuple[str, ...] = counterfactual.PREDICTED_KINDS) -> dict[str, Any]:
        w = env.world
        objs = [o for o in (_ALARMS[-1].get("objects") if _ALARMS else []) if o in w.objects][:2]
        pair = f"{objs[0]}-{objs[1]}" if len(objs) == 2 else ""
        if pair:
            print(f"  proactive alarm t={w.t:.3f}: true xy distance {pair} {_xy_distance(w, *objs) * 100:.2f} cm")
        print(f"  rollout plan: {[(a.skill, a.args.get('obj')) for a in counterfactual._remaining_plan(env)]}")
        n0, evaluate = len(w.events.events), env.evaluate

        def judged() -> Any:
            res = evaluate()
            if pair:
                print(f"  rollout end t={w.t:.3f}: true xy distance {pair} {_xy_distance(w, *objs) * 100:.2f} cm")
            print(f"  rollout verdict: {res.success} ({res.reason}); events "
                  f"{[(round(e['t'], 2), e['kind'], e.get('obj')) for e in w.events.events[n0:]]}")
            return res

        env.evaluate = judged
        try:
            return rollout(env, horizon_s, kinds)
        finally:
            del env.evaluate  # the class's method again

    episode.rollout = probed
    episode._Counterfactuals.__call__ = remember  # type: ignore[method-assign]


def _keys(results: str, conditions: list[str]) -> list[str]:
    out = []
    for r in episode_records(read_results(results)):
        if "ablation" not in r:  # CaM records (every ablation row too) carry it, the baselines' do not
            continue
        if conditions and r["condition"] not in conditions:
            continue
        if any(a.get("cf") and not a["cf"].get("confirmed") for a in r.get("alarms") or []):
            out.append("/".join(str(x) for x in record_key(r)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results")
    ap.add_argument("--key", action="append", default=[], help="CONDITION/METHOD/SEED/EPISODE (repeatable)")
    ap.add_argument("--conditions", default="", help="comma-separated; default: every condition")
    a = ap.parse_args()
    keys = a.key or _keys(a.results, [c for c in a.conditions.split(",") if c])
    _probe_final_check()
    _probe_alarms_and_rollouts()
    for key in keys:
        options, rec = find_record(a.results, key)
        print(f"== {key}: recorded success={rec['success']} ({rec['reason']}); run: {rec.get('run')}")
        for al in rec.get("alarms") or []:
            if al.get("cf"):
                print(f"  recorded alarm t={al['t']}: {al['reason']} -> confirmed={al['cf']['confirmed']}")
        condition, method, seed, ep = parse_key(key)
        _ALARMS.clear()
        new = episode.run_episode(Job(method=method, condition=condition, seed=seed, episode=ep),
                                  episode.EpisodeOptions(**options))
        print(f"  re-run: success={new['success']} ({new['reason']}), sim time {new['sim_time_s']} s")
        for al in new["alarms"]:
            cf = al.get("cf")
            print(f"  re-run alarm t={al['t']}: {al['reason']}" + (f" -> confirmed={cf['confirmed']}" if cf else ""))


if __name__ == "__main__":
    main()
