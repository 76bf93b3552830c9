"""Monitor programs: static validation, the sandbox worker, path coverage and per-frame evaluation.

Generated code is untrusted: it is checked against an AST allow-list (:mod:`.validate`) and only ever
compiled and run in a separate, kernel-confined worker process (:mod:`.sandbox`, :mod:`.worker`,
:mod:`.confine`). See ``docs/security.md`` for the threat model.

The names below are imported on first use, so that the worker process (which imports
:mod:`.worker` only) starts without the control-process modules.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "CoverageError": "coverage",
    "CoverageReport": "coverage",
    "check_path_coverage": "coverage",
    "MonitorRuntime": "runtime",
    "any_during_violated": "runtime",
    "during_violations": "runtime",
    "faults": "runtime",
    "unmet_upon": "runtime",
    "upon_satisfied": "runtime",
    "Sandbox": "sandbox",
    "validate_program": "validate",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
