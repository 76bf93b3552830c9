"""Import PyBullet without its banner.

``import pybullet`` prints ``pybullet build time: <date>`` from its C code straight to a file
descriptor (stderr in the builds we use), whatever ``sys.stdout``/``sys.stderr`` are, through C
stdio buffering. :func:`pybullet` imports the module once with descriptors 1 and 2 pointed at
``/dev/null`` and the C buffers flushed before they are restored, so nothing of the banner is left
to appear later. (Anything another thread writes to those descriptors during the import, a few
milliseconds, is lost too.)
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
import threading
from types import ModuleType

_lock = threading.Lock()


def pybullet() -> ModuleType:
    """The ``pybullet`` module, imported quietly the first time."""
    mod = sys.modules.get("pybullet")
    if mod is not None:
        return mod
    with _lock:
        if "pybullet" in sys.modules:
            return sys.modules["pybullet"]
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        saved: dict[int, int] = {}
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            for fd in (1, 2):
                with contextlib.suppress(OSError):  # a closed descriptor has nothing to protect
                    saved[fd] = os.dup(fd)
                    os.dup2(devnull, fd)
            import pybullet as pb

            with contextlib.suppress(Exception):
                ctypes.CDLL(None).fflush(None)  # push the banner out while it still goes to /dev/null
        finally:
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            os.close(devnull)
        return pb


__all__ = ["pybullet"]
