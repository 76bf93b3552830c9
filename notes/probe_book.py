"""One-off probe (outside the package): the true book pose against the tracked spine element, per frame.

Wraps ``make_tracker`` (as built by ``agent.build``) so each ``reset`` (a new paint) and each ``step`` logs:
the true spine direction (the book's local x from ``obs.object_poses['book']``) and its angle to vertical,
the tracked spine element's direction and angle, and the robot's grasp point. Then runs ``cam run`` with the
arguments given. Usage: python notes/probe_book.py OUT.jsonl -- <cam run args...>
"""
from __future__ import annotations

import json
import sys

import numpy as np

import code_as_monitor.perception as perception
from code_as_monitor.cli.main import main

OUT = open(sys.argv[1], "w")  # noqa: SIM115 (open for the whole run)
DUMP = __import__("os").environ.get("PROBE_DUMP")
ARGS = sys.argv[sys.argv.index("--") + 1:]
_make = perception.make_tracker


def _tilt(v: np.ndarray) -> float:
    v = np.asarray(v, float)
    return float(np.degrees(np.arccos(min(1.0, abs(v[2]) / max(np.linalg.norm(v), 1e-9)))))


def _tilt_to(v: np.ndarray, ref: np.ndarray) -> float:
    """Degrees between the lines along ``v`` and ``ref`` (3,)."""
    c = abs(float(v @ ref)) / max(float(np.linalg.norm(v) * np.linalg.norm(ref)), 1e-9)
    return float(np.degrees(np.arccos(min(1.0, c))))


class Probe:
    def __init__(self, inner):
        self.inner = inner
        self.spine_ids: list[int] = []

    def __getattr__(self, k):
        return getattr(self.inner, k)

    def _true(self, obs):
        T = obs.object_poses["book"]
        return {"t": round(obs.t, 3), "true_spine": np.round(T[:3, 0], 3).tolist(),
                "true_tilt": round(_tilt(T[:3, 0]), 1),
                "book_z": round(float(T[2, 3]), 3),
                "tip": np.round(obs.robot.ee_points.get("tip", [np.nan] * 3), 3).tolist(), "grip": obs.robot.gripper,
                "book_in_ee": np.round(obs.robot.ee_pose[:3, :3].T @ T[:3, 0], 2).tolist()}

    def reset(self, obs, elements):
        self.spine_ids = [el.id for el in elements if tuple(el.owner) == ("book", "spine")]
        rec = {"ev": "reset", **self._true(obs)}
        for el in elements:
            if el.id in self.spine_ids:
                p = np.asarray(el.points)
                d = p[-1] - p[0]
                rec[f"spine{el.id}"] = {"pts": np.round(p, 3).tolist(), "len": round(float(np.linalg.norm(d)), 3),
                                        "tilt": round(_tilt(d), 1),
                                        "support": repr(el.support),
                                        "angle_to_true": round(_tilt_to(d, obs.object_poses["book"][:3, 0]), 1)}
        OUT.write(json.dumps(rec) + "\n")
        OUT.flush()
        if DUMP and self.spine_ids and any(rec[f"spine{i}"]["angle_to_true"] > 45 for i in self.spine_ids):
            import pickle
            with open(f"{DUMP}-{obs.t:.3f}.pkl", "wb") as f:
                pickle.dump(obs, f)
        return self.inner.reset(obs, elements)

    def step(self, obs):
        r = self.inner.step(obs)
        rec = {"ev": "step", **self._true(obs)}
        for eid in self.spine_ids:
            p = np.asarray(r.points[eid])
            rec[f"spine{eid}_tilt"] = round(_tilt(p[-1] - p[0]), 1)
        OUT.write(json.dumps(rec) + "\n")
        return r


def make(cfg):
    return Probe(_make(cfg))


perception.make_tracker = make
sys.exit(main(["run", *ARGS]))
