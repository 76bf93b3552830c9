"""A live 3-D view with rerun-sdk (the optional ``rerun`` extra): stream to a viewer or save ``run.rrd``.

Logged on the ``time`` timeline (observation seconds):

- ``views/<view>/image``: every judged frame of every camera, with ``views/<view>/elements``: the
  numbered elements projected into it (label ``<id> <name>``; stale points greyed);
- ``world/cameras/<view>``: each camera's pose and pinhole (the images in 3-D);
- ``world/elements/<id>``: the elements in 3-D (points; lines and surfaces as strips) labelled with
  their number, name and owner; ``world/end_effector``: the tool pose and its named points;
- ``checks/<constraint>/margin``: each check's margin (> 0 satisfied) every judged frame;
- ``events/alarms`` and ``events/replans``: a marker at every alarm (its constraint and reason) and
  every re-plan, also as text in ``events/log``.

The sink is chosen once: ``save`` (a file, opened later with ``rerun run.rrd``, offline), ``spawn``
(start a local viewer and stream to it) or ``connect`` (stream to a running viewer's gRPC URL).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.extras import require

SINKS = ("save", "spawn", "connect")
URL_SCHEMES = ("rerun://", "rerun+http://", "rerun+https://")
"""The schemes rerun-sdk accepts for a viewer's gRPC URL."""


def check_url(url: str) -> None:
    """ConfigError naming ``url`` when it is not a rerun gRPC URL (checked before anything is started)."""
    if not url.startswith(URL_SCHEMES):
        raise ConfigError(f"rerun URL {url!r} must start with one of {', '.join(URL_SCHEMES)} "
                          "(e.g. rerun+http://127.0.0.1:9876/proxy)")
GREY = (128, 128, 128)


class RerunLogger:
    """Logs frames (``on_frame``) and events (``on_event``) of one run to a rerun recording.

    Args:
        sink: ``save`` (to ``path``), ``spawn`` or ``connect`` (to ``url``; None: the default viewer).
        path: the ``.rrd`` file for ``save``.
        url: the viewer's gRPC URL for ``connect`` (e.g. ``rerun+http://127.0.0.1:9876/proxy``).
        name: the recording's application id.
    """

    def __init__(self, sink: str = "save", path: Path | None = None, url: str | None = None,
                 name: str = "code-as-monitor") -> None:
        if sink not in SINKS:
            raise ConfigError(f"rerun sink must be one of {', '.join(SINKS)}, got {sink!r}")
        if sink == "save" and path is None:
            raise ConfigError("rerun sink 'save' needs a path for run.rrd")
        if url is not None:
            check_url(url)
        rr = require("rerun", "rerun")
        self.rr = rr
        self.rec = rr.RecordingStream(name)
        if sink == "save":
            self.rec.save(str(path))
        elif sink == "spawn":
            self.rec.spawn()
        else:
            self.rec.connect_grpc(url) if url else self.rec.connect_grpc()
        self.path = path
        self._cams_logged: set[str] = set()
        self._replans = 0
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)

    # --- frames -------------------------------------------------------------------------------------------
    def on_frame(self, obs: Any, elements: list[Any], stale: dict[int, np.ndarray] | None, verdicts: list[Any],
                 banner: str) -> None:
        rr, rec = self.rr, self.rec
        rec.set_time("time", duration=float(obs.t))
        stale = stale or {}
        for name, v in obs.views.items():
            cam = v.camera
            rec.log(f"world/cameras/{name}", rr.Transform3D(translation=cam.T_world_cam[:3, 3],
                                                            mat3x3=cam.T_world_cam[:3, :3]))
            if name not in self._cams_logged:
                rec.log(f"world/cameras/{name}", rr.Pinhole(image_from_camera=cam.K, width=cam.width,
                                                            height=cam.height), static=True)
                self._cams_logged.add(name)
            rec.log(f"views/{name}/image", rr.Image(v.rgb))
            pts, labels, colors = [], [], []
            for e in elements:
                uv, z = cam.project(np.asarray(e.points, dtype=np.float64))
                st = np.asarray(stale.get(e.id, np.zeros(len(e.points), bool)))
                for k, p in enumerate(uv):
                    if z[k] > 0 and np.all(np.isfinite(p)):
                        pts.append(p)
                        labels.append(f"{e.id} {e.name}")
                        colors.append(GREY if (k < len(st) and st[k]) else tuple(e.color))
            rec.log(f"views/{name}/elements", rr.Points2D(np.array(pts).reshape(-1, 2), labels=labels, colors=colors,
                                                          radii=3.0, show_labels=True))
        for e in elements:
            p = np.asarray(e.points, dtype=np.float64).reshape(-1, 3)
            label = f"{e.id} {e.name} ({'/'.join(x for x in e.owner if x)})"
            kind = getattr(e.kind, "value", str(e.kind))
            if kind == "point" or len(p) == 1:
                rec.log(f"world/elements/{e.id}", rr.Points3D(p, labels=[label], colors=[e.color], radii=0.008,
                                                              show_labels=True))
            else:
                strip = np.vstack([p, p[:1]]) if kind == "surface" else p
                rec.log(f"world/elements/{e.id}", rr.LineStrips3D([strip], labels=[label], colors=[e.color],
                                                                  radii=0.004, show_labels=True))
        robot = obs.robot
        if robot is not None:
            T = np.asarray(robot.ee_pose, dtype=np.float64)
            rec.log("world/end_effector", rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                    rr.TransformAxes3D(axis_length=0.08))
            names = list(robot.ee_points)
            if names:
                rec.log("world/end_effector_points", rr.Points3D(np.array([robot.ee_points[n] for n in names]),
                                                                 labels=names, radii=0.006))
        for vd in verdicts:
            if vd.margin is not None and np.isfinite(vd.margin):
                rec.log(f"checks/{vd.constraint_id}/margin", rr.Scalars(float(vd.margin)))

    # --- events ------------------------------------------------------------------------------------------
    def on_event(self, ev: dict[str, Any]) -> None:
        rr, rec = self.rr, self.rec
        kind = ev.get("kind")
        t = ev.get("t")
        if isinstance(t, (int, float)):
            rec.set_time("time", duration=float(t))
        if kind == "alarm":
            tag = "PROACTIVE" if ev.get("proactive") else "REACTIVE"
            rec.log("events/alarms", rr.Scalars(1.0))
            rec.log(f"checks/{ev['constraint_id']}/alarm", rr.Scalars(0.0))
            text = f"{tag} {ev['constraint_id']}: {ev['reason']}"
            rec.log("events/log", rr.TextLog(text, level=rr.TextLogLevel.WARN))
        elif kind == "subgoal_end" and ev.get("outcome") != "success":
            self._replans += 1
            rec.log("events/replans", rr.Scalars(float(self._replans)))
            rec.log("events/log", rr.TextLog(f"re-plan after {ev['outcome']}: {ev.get('reason', '')}",
                                             level=rr.TextLogLevel.INFO))
        elif kind == "subgoal":
            rec.log("events/log", rr.TextLog(f"subgoal {ev['index']}: {ev['subgoal']['text']}"))
        elif kind in ("task_complete", "episode_end"):
            rec.log("events/log", rr.TextLog(f"{kind}: {ev.get('stop_reason', '')}"))

    def close(self) -> None:
        self.rec.flush()
        self.rec.disconnect()


__all__ = ["SINKS", "RerunLogger"]
