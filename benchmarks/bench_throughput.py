"""Benchmark: episodes per hour of each benchmark method, in this process, without videos.

Runs ``--episodes`` episodes (seed index 0) of every method on each ``--conditions`` cell, the methods
interleaved episode by episode (so a change in the machine's load hits them alike), ``--repeats``
times, and reports per method the median over the repeats of episodes per hour of one core: by wall
time (what a run takes here) and by CPU time (this process and its sandbox workers: what the episode
costs, less inflated by other load on a shared machine), the ratio of each against open-loop measured
in the same process, and the camera images rendered per episode (a method renders only the views and
frames it reads). Offline: the kb planner, and for the baselines the ``vqa-standin`` single-image
stand-in (not a VLM); CaM with the ``sim`` segmenter and ``--tracker`` (default ``depth``, ``cam bench``'s default
since the fifteenth session; ``sim`` the oracle).

``--estimate RESULTS.jsonl`` instead estimates the full CLIPort protocol's wall time from a results
file of a sample of it (``cam bench --seeds 2 --episodes 4 ...``): the mean per-episode time of each
(condition, method) cell times the protocol's episodes per cell, summed, divided by ``--workers``.

``--robot-visuals mesh,decimated,hull`` runs every method with the arm drawn each way (``cam bench --robot-visual``:
``decimated`` the default, ``mesh`` the full meshes, ``hull`` the collision meshes) and prints each one's ratio of
episodes per hour against ``mesh``. ``CAM_SANDBOX_SPAWN=exec`` in the environment starts sandbox workers as new
interpreters instead of forking them (the cost before the fork server).

Run: ``.venv/bin/python benchmarks/bench_throughput.py [--conditions stack-p0.15,rope] [--episodes 2] [--tracker sim]``.
The last lines are machine-readable: ``name: value unit``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from collections import defaultdict

from code_as_monitor.bench.episode import EpisodeOptions, run_episode
from code_as_monitor.bench.protocol import FULL, METHODS, SUITES, Job


def _cpu_seconds() -> float:
    """CPU seconds of this process, its finished children and the sandbox's fork server where the code has
    one (measured here, so that the script also times code whose records carry no ``cpu_time_s``:
    ``PYTHONPATH=<other checkout>/src``)."""
    try:
        from code_as_monitor.monitor.forkserver import server_cpu_seconds
    except ImportError:  # code from before the fork server: its workers are finished children
        def server_cpu_seconds() -> float:
            return 0.0
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system + server_cpu_seconds()


def _label(method: str, visual: str, visuals: list[str]) -> str:
    return method if len(visuals) == 1 else f"{method}@{visual}"


def measure(methods: list[str], conds: list[str], episodes: int, repeats: int,
            tracker: str = "depth", visuals: tuple[str, ...] = ("decimated",)) -> dict[str, dict[str, float]]:
    """Per method (and robot visual, labelled ``method@visual`` when more than one): median episodes/hour by wall
    and by CPU time, and mean images per episode (CaM with ``tracker``); the visuals interleaved like the methods."""
    vis = list(visuals)
    runs = [(m, v) for m in methods for v in vis]
    rates: dict[str, dict[str, list[float]]] = {_label(m, v, vis): defaultdict(list) for m, v in runs}
    images: dict[str, list[float]] = defaultdict(list)
    opts = {v: EpisodeOptions(tracker=tracker, robot_visual=v) for v in vis}
    for v in vis:
        run_episode(Job(methods[0], conds[0], 1, 0), opts[v])  # imports and caches, not timed
    for r in range(repeats):
        walls: dict[str, list[float]] = defaultdict(list)
        cpus: dict[str, list[float]] = defaultdict(list)
        for c in conds:
            for e in range(episodes):
                for m0, v in runs:
                    m = _label(m0, v, vis)
                    cpu0 = _cpu_seconds()
                    rec = run_episode(Job(m0, c, 0, e), opts[v])
                    if rec.get("error"):
                        print(f"  {m} {c} e{e}: error {rec['error']}", file=sys.stderr)
                    walls[m].append(rec["wall_time_s"])
                    cpus[m].append(_cpu_seconds() - cpu0)
                    if r == 0 and rec.get("images") is not None:
                        images[m].append(rec["images"])
        for m in methods:
            rates[m]["wall"].append(3600.0 / statistics.fmean(walls[m]))
            rates[m]["cpu"].append(3600.0 / statistics.fmean(cpus[m]))
            print(f"repeat {r}: {m:16s} {statistics.fmean(walls[m]):6.2f} s wall, "
                  f"{statistics.fmean(cpus[m]):6.2f} s cpu per episode", flush=True)
    return {m: {"wall": statistics.median(v["wall"]), "cpu": statistics.median(v["cpu"]),
                "images": statistics.fmean(images[m]) if images[m] else float("nan")} for m, v in rates.items()}


def estimate(path: str, workers: int, seeds: int, episodes: int) -> list[tuple[str, float, str]]:
    """Full-protocol minutes estimated from a sample results file (see the module doc)."""
    from code_as_monitor.bench.runner import episode_records, read_results

    cells: dict[tuple[str, str], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in episode_records(read_results(path)):
        cells[(r["condition"], r["method"])]["wall"].append(r["wall_time_s"])
        if r.get("cpu_time_s") is not None:
            cells[(r["condition"], r["method"])]["cpu"].append(r["cpu_time_s"])
    n = seeds * episodes
    out: list[tuple[str, float, str]] = []
    for kind in ("wall", "cpu"):
        per_method: dict[str, float] = defaultdict(float)
        for (cond, method), v in sorted(cells.items()):
            if cond in SUITES["cliport"] and v[kind]:
                per_method[method] += statistics.fmean(v[kind]) * n / 60.0
        if not per_method:
            continue
        for m, minutes in per_method.items():
            print(f"{kind}: {m:16s} {minutes:7.1f} core-min over the protocol")
        out.append((f"full_protocol_estimate_{kind}", sum(per_method.values()) / workers, "min"))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--conditions", default="stack-p0.15", help="comma list of condition ids")
    ap.add_argument("--episodes", type=int, default=2, help="episodes per method and condition")
    ap.add_argument("--repeats", type=int, default=3, help="rounds over every episode (median reported)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--tracker", default="depth", help="CaM's tracker: depth (cam bench's default) or sim (the oracle)")
    ap.add_argument("--robot-visuals", default="decimated",
                    help="comma list of how the cameras draw the arm: decimated (cam bench's default), mesh (the full "
                         "meshes), hull (its collision meshes); with several, each method runs with each, interleaved, "
                         "and the ratios against mesh are printed")
    ap.add_argument("--estimate", default=None, help="a sample's results file: estimate the full protocol")
    ap.add_argument("--workers", type=int, default=2, help="episodes at once for --estimate")
    args = ap.parse_args(argv)
    if args.estimate:
        figures = estimate(args.estimate, args.workers, *FULL)
    else:
        methods = [x for x in args.methods.split(",") if x]
        visuals = [x for x in args.robot_visuals.split(",") if x]
        res = measure(methods, [c for c in args.conditions.split(",") if c], args.episodes, args.repeats,
                      args.tracker, tuple(visuals))
        figures = []
        for m, r in res.items():
            print(f"{m:16s} images/episode {r['images']:6.1f}")
            figures.append((f"episodes_per_hour_wall {m}", r["wall"], "episodes/h"))
            figures.append((f"episodes_per_hour_cpu {m}", r["cpu"], "episodes/h"))
            base, _, vis = m.partition("@")
            ref = res.get(_label("open-loop", vis or visuals[0], visuals))
            if ref is not None and base != "open-loop":
                figures.append((f"ratio_vs_open_loop_wall {m}", r["wall"] / ref["wall"], "x"))
                figures.append((f"ratio_vs_open_loop_cpu {m}", r["cpu"] / ref["cpu"], "x"))
            mesh = res.get(_label(base, "mesh", visuals))
            if vis and vis != "mesh" and mesh is not None:  # episodes/hour, so > 1 is faster
                figures.append((f"ratio_{vis}_vs_mesh_cpu {base}", r["cpu"] / mesh["cpu"], "x"))
    for name, value, unit in figures:
        print(f"{name}: {value:.3g} {unit}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
