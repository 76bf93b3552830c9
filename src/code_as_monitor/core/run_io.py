"""Run artefacts: fresh run directories and append-only JSONL event logs flushed as written.

A run never overwrites another: :func:`new_run_dir` picks a fresh name, and :class:`EventLog`
refuses to reopen a file for writing unless asked to append (resume).
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from code_as_monitor.core.errors import RunError


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        f = float(x)
        return None if math.isnan(f) or math.isinf(f) else f
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if hasattr(x, "to_dict"):
        return _jsonable(x.to_dict())
    if hasattr(x, "value") and isinstance(getattr(x, "value", None), str):  # Enum
        return x.value
    return x


def to_json(obj: Any) -> str:
    """One-line JSON of ``obj`` (numpy arrays, enums and objects with ``to_dict`` converted; NaN -> null)."""
    return json.dumps(_jsonable(obj), separators=(",", ":"), sort_keys=False)


def new_run_dir(root: str | os.PathLike[str] = "runs", prefix: str = "run") -> Path:
    """Create and return a fresh directory ``root/<prefix>-<UTC timestamp>[-N]``; never reuses one."""
    root_p = Path(root)
    root_p.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
    for n in range(1000):
        name = f"{prefix}-{stamp}" if n == 0 else f"{prefix}-{stamp}-{n}"
        path = root_p / name
        try:
            path.mkdir()
        except FileExistsError:
            continue
        return path
    raise RunError(f"could not create a fresh run directory under {root_p}")


class EventLog:
    """Append-only JSONL log; every event is written and flushed immediately.

    Args:
        path: the ``.jsonl`` file.
        append: open an existing file to append (resume); otherwise the file must not exist.
    """

    def __init__(self, path: str | os.PathLike[str], append: bool = False) -> None:
        self.path = Path(path)
        if self.path.exists() and not append:
            raise RunError(f"event log {self.path} exists already; refusing to overwrite it")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.path, "a", encoding="utf-8")  # noqa: SIM115 - closed in close()

    def write(self, kind: str, **fields: Any) -> dict[str, Any]:
        """Write one event ``{"kind": kind, **fields}`` and flush; returns the event."""
        event = {"kind": kind, **fields}
        self._fh.write(to_json(event) + "\n")
        self._fh.flush()
        return event

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> EventLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_jsonl(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Read a JSONL file; a truncated last line (a killed writer) is ignored, other bad lines raise RunError.

    A line is truncated only when the file does not end with a newline (every record is written with its
    own) and it follows a complete one: a file whose only line is not JSON is not a results file."""
    out: list[dict[str, Any]] = []
    text = Path(path).read_text(encoding="utf-8")
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError as exc:
            if i == len(lines) - 1 and out and not text.endswith("\n"):
                break
            raise RunError(f"{path}:{i + 1}: not valid JSON ({exc.msg})") from None
    return out


def write_json(path: str | os.PathLike[str], obj: Any) -> None:
    """Write ``obj`` as indented JSON atomically (temp file then rename)."""
    p = Path(path)
    tmp = p.with_suffix(p.suffix + ".tmp")
    tmp.write_text(json.dumps(_jsonable(obj), indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, p)
