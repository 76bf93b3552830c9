"""The sentences every benchmark report states above its tables: which perception and cameras the methods used.

An oracle figure must never pass for a realistic one, so each report (CLIPort and Table 2, ablation, RLBench-style)
says how CaM's elements were painted and tracked, and on which camera set every method ran.
"""

from __future__ import annotations

from typing import Any


def tracker_phrase(tracker: str) -> str:
    """```sim` (the oracle: ground-truth poses)`` or ```depth` (no simulator poses)``."""
    return f"`{tracker}`" + (" (the oracle: ground-truth poses)" if tracker == "sim" else " (no simulator poses)")


def planner_phrase(backend: str) -> str:
    """```kb` (a rule-based stand-in for a VLM, not a VLM)`` or ```openai```."""
    return f"`{backend}`" + (" (a rule-based stand-in for a VLM, not a VLM)" if backend == "kb" else "")


def cameras_note(opts: dict[str, Any]) -> str:
    """`` Cameras: ...`` for a sweep on a named camera set; "" for each task's own views (the default)."""
    cams = opts.get("cameras", "task")
    note = "" if cams == "task" else (f" Cameras: the `{cams}` set for every method (the baselines ask each question "
                                      f"on its view most like the one they want).")
    visual = opts.get("robot_visual", "mesh")  # a results file without the field drew the full mesh
    note += {"decimated": " The arm drawn with its decimated meshes (a fifth of the triangles; under 1 % of its "
                          "pixels change label).",
             "mesh": " The arm drawn with its full detailed meshes.",
             "hull": " The arm drawn with its `hull` visual (its collision meshes, not its detailed meshes: the "
                     "same physics, a plainer and slightly larger arm in every image)."}.get(visual, "")
    return note


def perception_note(opts: dict[str, Any]) -> str:
    """One line: CaM's masks, tracker and planner, and the cameras, from a results file's method options."""
    return (f"CaM perception: elements painted from `{opts.get('segmenter', 'sim')}` masks, tracked by "
            f"{tracker_phrase(opts.get('tracker', 'sim'))}; planner and coder: "
            f"{planner_phrase(opts.get('backend', 'kb'))}." + cameras_note(opts))


__all__ = ["cameras_note", "perception_note", "planner_phrase", "tracker_phrase"]
