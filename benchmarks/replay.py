"""Benchmark: how much faster than real time a recorded RGB-D bag replays through the whole monitor.

Records one closed-loop episode as an MCAP bag (``cam record``'s path: two 320x240 views at 10 Hz,
32FC1 depth; stack-in-order with placement noise q = 3 cm; kb planner, a rule-based stand-in for a
VLM; ``sim`` segmenter; LK tracker, not the oracle), then replays its first ``--seconds`` (20 s)
``--repeats`` times with ``--rate max`` and reports the median of ``replayed seconds / wall time``. The reference,
measured in the same run: the same replay with every frame already decoded in memory (the monitor
alone), so the ratio says what reading the bag costs.

Run: ``.venv/bin/python benchmarks/replay.py [--repeats 3] [--bag ep.mcap] [--deadline 0.5]`` (``--bag``: reuse or
keep the recording). Target: replay_realtime_factor >= 3. Wall-clock figures: run it on an otherwise idle machine;
the load average is printed next to them. The sandbox deadline is 0.5 s per frame by default, as in ``cam bench``:
at ``--rate max`` the recording waits for the monitor, and on a loaded machine a 20 ms budget replaces workers
(each replacement is a fresh interpreter) and turns frames into faults, so the figure would measure the load.
``--deadline 0.02`` measures ``cam monitor``'s real-time default.

CPU seconds are printed too (the control process and its sandbox workers, which start one fresh interpreter per
loaded program: path coverage and the program itself at every subgoal): ``replay_cpu_realtime_factor`` is the
replayed seconds per CPU second, what one core with nothing else to run would reach if no work overlapped.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path

from code_as_monitor.bench.closed_loop import ClosedLoopConfig
from code_as_monitor.bench.record import record_episode
from code_as_monitor.bench.replay import replay_bag
from code_as_monitor.recordings.reader import BagSource

EPISODE = ClosedLoopConfig(task="stack-in-order", seed=1262352492, task_params={"q": 3.0}, tracker="lk",
                           width=320, height=240, camera_hz=10.0, video=False)


class FirstSeconds:
    """The frames of ``src`` before ``seconds`` (decoded as they are read, or all up front: the reference,
    the monitor without bag reading)."""

    def __init__(self, src: BagSource, seconds: float, in_memory: bool) -> None:
        self.src, self.seconds = src, seconds
        self.path, self.stats, self.ground_truth = src.path, src.stats, []
        self.duration_s = min(seconds, src.duration_s)
        self.frames = list(self._take()) if in_memory else None

    def _take(self):
        for obs, done in self.src:
            if obs.t >= self.seconds - 1e-9:
                return
            yield obs, done

    def __iter__(self):
        return iter(self.frames) if self.frames is not None else self._take()


def _children_cpu() -> float:
    """CPU seconds of the waited-for child processes (the sandbox workers, once collected)."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--bag", type=Path, default=None, help="recording to reuse (made there when missing)")
    ap.add_argument("--deadline", type=float, default=0.5, help="sandbox deadline per frame, s (default 0.5)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as d:
        bag = args.bag or Path(d) / "ep.mcap"
        if not bag.exists():
            t0 = time.perf_counter()
            record_episode(EPISODE, bag)
            print(f"recorded {bag.stat().st_size / 1e6:.0f} MB in {time.perf_counter() - t0:.0f} s")
        src = BagSource(bag)
        cfg = dataclasses.replace(EPISODE.monitor_config(src.metadata["time_limit_s"]), deadline_s=args.deadline)
        instruction = src.metadata["instruction"]
        mem = FirstSeconds(src, args.seconds, in_memory=True)
        factors, ref, cpu = [], [], []
        for _ in range(args.repeats):
            source = FirstSeconds(BagSource(bag), args.seconds, in_memory=False)  # indexing the bag: not timed
            c0, k0 = time.process_time(), _children_cpu()
            s = replay_bag(source, instruction, cfg, video=False)
            factors.append(s["replay_realtime_factor"])
            cpu.append((time.process_time() - c0, _children_cpu() - k0))
            r = replay_bag(mem, instruction, cfg, video=False)
            ref.append(r["replay_realtime_factor"])
        alarms = len(s["episode"]["alarms"])
        print(f"replayed: the first {mem.duration_s:.1f} s of a {src.duration_s:.1f} s episode, {len(mem.frames)} "
              f"frames, 2 views 320x240, {alarms} alarms")
    f, r = statistics.median(factors), statistics.median(ref)
    main_cpu, workers_cpu = statistics.median(c for c, _ in cpu), statistics.median(w for _, w in cpu)
    print(f"sandbox deadline {args.deadline:g} s; load average (1 min) {load0[0]:.1f} before, "
          f"{os.getloadavg()[0]:.1f} after, on {os.cpu_count()} CPUs")
    print(f"replay_cpu_s_control_process: {main_cpu:.2f} s")
    print(f"replay_cpu_s_sandbox_workers: {workers_cpu:.2f} s")
    print(f"replay_cpu_realtime_factor: {mem.duration_s / (main_cpu + workers_cpu):.2f} x")
    print(f"replay_realtime_factor: {f:.2f} x")
    print(f"in_memory_realtime_factor: {r:.2f} x")
    print(f"bag_reading_cost_ratio: {r / f:.3f} x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
