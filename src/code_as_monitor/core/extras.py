"""The one place that checks optional dependencies (extras) and says which extra to install."""

from __future__ import annotations

import importlib
from types import ModuleType

from code_as_monitor.core.errors import MissingExtraError

INSTALL = {
    "ros": "pip install -e '.[ros]'  (rosbags: ROS 2 bags without a ROS install; part of `make install`)",
    "rerun": "pip install -e '.[rerun]'  (rerun-sdk, ~500 MB; or `make install EXTRAS=dev,sim,ray,ros,rerun`)",
    "ray": "pip install -e '.[ray]'",
}


def require(module: str, extra: str) -> ModuleType:
    """Import ``module`` or raise MissingExtraError naming the extra that provides it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(f"{module} is not installed; it comes with the {extra!r} extra: "
                                f"{INSTALL.get(extra, extra)}") from None


def available(module: str) -> bool:
    """Whether ``module`` can be imported (no import side effects beyond the import itself)."""
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


__all__ = ["INSTALL", "available", "require"]
