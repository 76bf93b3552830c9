"""Cameras from a JSON file: a user's own views for a simulated episode (``cam run --cameras my_views.json``).

The file holds a list of cameras, or an object with a ``"cameras"`` list. Each camera is an object with the
fields of :class:`~code_as_monitor.sim.cameras.CameraSpec`:

.. code-block:: json

    {"cameras": [
      {"name": "left_low", "eye": [0.5, 0.7, 0.35], "target": [0.5, 0.0, 0.05], "fov_y_deg": 55},
      {"name": "over_head", "eye": [0.45, 0.0, 1.4], "target": [0.45, 0.0, 0.0], "up": [1, 0, 0]},
      {"name": "hand", "eye": [0.0, 0.055, 0.0], "target": [0.0, 0.0, 0.2], "mount": "wrist", "up": [1, 0, 0]}
    ]}

``name``, ``eye`` and ``target`` are required (world frame, metres; a ``"wrist"`` camera's are in the hand's
grasp frame, see :mod:`~code_as_monitor.sim.cameras`); ``fov_y_deg`` (default 50), ``near``, ``far``, ``up``,
``mount``, ``width`` and ``height`` are optional (the size defaults to ``cam run --size``). Every bad value is a
:class:`~code_as_monitor.core.errors.ConfigError` naming the file, the camera and the field.
"""

from __future__ import annotations

import json
import math
from dataclasses import fields
from pathlib import Path
from typing import Any

from code_as_monitor.core.checks import IMAGE_SIDE_RANGE
from code_as_monitor.core.errors import ConfigError

SUFFIX = ".json"
"""A ``--cameras`` value ending in this is a camera file, not a named set."""

_VECTORS = ("eye", "target", "up")
_NUMBERS = ("fov_y_deg", "near", "far")
_INTEGERS = ("width", "height")


def is_camera_file(name: str) -> bool:
    """Whether a ``--cameras`` value names a camera file (it ends in :data:`SUFFIX`)."""
    return name.lower().endswith(SUFFIX)


def load_camera_file(path: str | Path, width: int, height: int, spec: type) -> list[Any]:
    """The camera specs (``spec``: :class:`~code_as_monitor.sim.cameras.CameraSpec`, the dataclass each camera
    becomes) of camera file ``path`` (module docstring); ``width`` x ``height`` for the cameras that give no size.
    ConfigError names a missing or unreadable file, bad JSON, an unknown or missing field, a bad value or a repeated
    name."""
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except FileNotFoundError:
        raise ConfigError(f"camera file {str(p)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"camera file {str(p)!r} cannot be read: {e}") from None
    except json.JSONDecodeError as e:
        raise ConfigError(f"camera file {str(p)!r} is not JSON: {e}") from None
    cams = data.get("cameras") if isinstance(data, dict) else data
    if not isinstance(cams, list) or not cams:
        raise ConfigError(f"camera file {str(p)!r} must hold a non-empty list of cameras (or {{\"cameras\": [...]}}), "
                          f"got {type(cams).__name__}")
    known = {f.name for f in fields(spec)}
    specs, names = [], set()
    for i, cam in enumerate(cams):
        where = f"camera file {str(p)!r}, camera {i}"
        if not isinstance(cam, dict):
            raise ConfigError(f"{where} must be an object, got {cam!r}")
        unknown = sorted(set(cam) - known)
        if unknown:
            raise ConfigError(f"{where}: unknown field(s) {', '.join(map(repr, unknown))}; the fields are "
                              f"{', '.join(sorted(known))}")
        missing = [k for k in ("name", "eye", "target") if k not in cam]
        if missing:
            raise ConfigError(f"{where}: missing {', '.join(map(repr, missing))}")
        name = cam["name"]
        if not isinstance(name, str) or not name.strip():
            raise ConfigError(f"{where}: name must be a non-empty string, got {name!r}")
        if name in names:
            raise ConfigError(f"{where}: the name {name!r} is used twice")
        names.add(name)
        kw = {k: _value(f"{where} ({name!r})", k, v) for k, v in cam.items() if k != "name"}
        kw.setdefault("width", width)
        kw.setdefault("height", height)
        if kw["eye"] == kw["target"]:
            raise ConfigError(f"{where} ({name!r}): eye and target are the same point {kw['eye']}")
        try:
            specs.append(spec(name, **kw))
        except ConfigError as e:
            raise ConfigError(f"{where}: {e}") from None
    return specs


def _value(where: str, key: str, v: Any) -> Any:
    """``v`` checked for field ``key`` (a 3-vector, a finite number, a positive size or the mount's name)."""
    if key in _VECTORS:
        if v is None and key == "up":
            return None
        if not isinstance(v, list) or len(v) != 3 or not all(_finite(x) for x in v):
            raise ConfigError(f"{where}: {key} must be 3 finite numbers (metres), got {v!r}")
        return tuple(float(x) for x in v)
    if key in _NUMBERS:
        if not _finite(v):
            raise ConfigError(f"{where}: {key} must be a finite number, got {v!r}")
        return float(v)
    if key in _INTEGERS:
        lo, hi = IMAGE_SIDE_RANGE
        if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
            raise ConfigError(f"{where}: {key} must be an integer from {lo} to {hi} (pixels), got {v!r}")
        return v
    if not isinstance(v, str):  # mount: CameraSpec names the choices
        raise ConfigError(f"{where}: {key} must be a string, got {v!r}")
    return v


def _finite(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


__all__ = ["SUFFIX", "is_camera_file", "load_camera_file"]
