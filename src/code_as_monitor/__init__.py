"""Code-as-Monitor: constraint-aware visual programming for reactive and proactive failure detection.

The package is layered (see ``docs/architecture.md``): ``core`` -> ``geometry`` -> ``perception``/``vlm``
-> ``painter``/``monitor`` -> ``planning`` -> ``agent`` -> ``sim``/``baselines``/``recordings`` ->
``bench``/``viz``/``cli``. Importing the package imports no backend; the streaming API
(:class:`Monitor`, :class:`MonitorConfig`, :class:`Decision`) is loaded on first use.
"""

from __future__ import annotations

from typing import Any

__version__ = "0.1.0"

_LAZY = {
    "Monitor": "code_as_monitor.agent.monitor",
    "MonitorConfig": "code_as_monitor.agent.config",
    "Decision": "code_as_monitor.agent.decision",
    "DecisionKind": "code_as_monitor.agent.decision",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'code_as_monitor' has no attribute {name!r}")


__all__ = ["Decision", "DecisionKind", "Monitor", "MonitorConfig", "__version__"]
