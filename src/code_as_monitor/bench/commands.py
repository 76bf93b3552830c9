"""The commands that re-run a benchmark record: ``cam reproduce RESULTS --key KEY`` and, for CaM, ``cam run ...``.

Every episode record carries ``reproduce``; CaM records also carry ``run`` (see :mod:`code_as_monitor.bench.reproduce`,
which re-runs a record and compares). The episode code and the runner write these commands; this module imports
neither of them, so the re-run (which calls both) forms no import circle with them.
"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Any

from code_as_monitor.core.errors import ConfigError


def record_key_text(r: dict[str, Any]) -> str:
    """``condition/method/seed/episode`` of a record."""
    return f"{r['condition']}/{r['method']}/{int(r['seed'])}/{int(r['episode'])}"


def parse_key(key: str) -> tuple[str, str, int, int]:
    """(condition, method, seed, episode) from ``condition/method/seed/episode``; ConfigError naming a bad one."""
    parts = str(key).split("/")
    if len(parts) != 4 or not parts[2].isdigit() or not parts[3].isdigit():
        raise ConfigError(f"--key must look like CONDITION/METHOD/SEED/EPISODE (e.g. stack-p0.3/cam/0/3), got {key!r}")
    return parts[0], parts[1], int(parts[2]), int(parts[3])


def reproduce_command(results: str | Path, r: dict[str, Any]) -> str:
    """``cam reproduce RESULTS --key KEY`` for record ``r`` of ``results``."""
    return f"cam reproduce {shlex.quote(str(results))} --key {shlex.quote(record_key_text(r))}"


def run_command(task: str, episode_seed: int, params: dict[str, Any], options: dict[str, Any],
                ablation: str = "full") -> str:
    """The ``cam run`` command that runs the same CaM episode as the benchmark (see the module docstring)."""
    from code_as_monitor.agent.records import DEFAULT_MAX_REPLANS
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig

    cfg = ClosedLoopConfig()
    words = ["cam", "run", task, "--seed", str(int(episode_seed))]
    for k, v in sorted(params.items()):
        words += ["--set", f"{k}={v}"]
    words += ["--backend", str(options.get("backend", "kb")), "--segmenter", str(options.get("segmenter", "sim")),
              "--tracker", str(options.get("tracker", "sim")), "--size", f"{cfg.width}x{cfg.height}",
              "--camera-hz", f"{float(options.get('camera_hz', cfg.camera_hz)):g}",
              "--max-replans", str(int(options.get("max_replans") if options.get("max_replans") is not None
                                       else DEFAULT_MAX_REPLANS)),  # the rlbench suite runs with 0
              "--deadline", f"{float(options.get('deadline_s', cfg.deadline_s)):g}"]
    if options.get("cameras", "task") != "task":
        words += ["--cameras", str(options["cameras"])]
    visual = options.get("robot_visual", "mesh")  # a record without the field drew the full mesh
    if visual != "decimated":
        words += ["--robot-visual", str(visual)]
    if ablation != "full":
        words += ["--ablation", ablation]
    if options.get("backend_options"):
        words.append("# backend options: " + ", ".join(f"{k}={v}" for k, v in options["backend_options"].items()))
    return " ".join(shlex.quote(w) if not w.startswith("#") else w for w in words)


__all__ = ["parse_key", "record_key_text", "reproduce_command", "run_command"]
