"""A sandbox worker whose first two layers have failed, for testing the kernel layer and the host end to end.

It is the real worker (imports, warm-up, resource limits, confinement, protocol), except that a program is
neither validated nor restricted: it runs with the real builtins (``open``, ``__import__``, ``getattr``,
``exec`` ...), and ``os``, ``sys``, ``socket``, ``threading``, ``subprocess``, ``signal``, ``ctypes``,
``mmap`` and ``resource`` are imported before the filter goes on, so ``__import__`` hands them over. That
is what a program would have after a full escape from the allow-list and the namespace (the issue's
raw-memory attack recovered the real builtins): whatever it then does must be stopped by the kernel
(seccomp, namespaces, resource limits) or contained by the control process. Started through :data:`BOOT`
in place of the worker's boot line; the control process's own validation must be patched out as well
(see ``test_monitor_breach.py``).
"""

from __future__ import annotations

import ast
import builtins
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
BOOT = ("import time; t0 = time.perf_counter(); import sys; sys.path.insert(0, sys.argv[1]); "
        f"sys.path.insert(0, {HERE!r}); import breached_worker; breached_worker.run(t0)")


def parse_only(source: str, constraints: list) -> ast.Module:
    """Stands in for ``validate_program``: parses, checks nothing."""
    return ast.parse(source)


def run(t0: float) -> None:
    import ctypes  # noqa: F401  (imported so that a breached program can reach them)
    import mmap  # noqa: F401
    import resource  # noqa: F401
    import signal  # noqa: F401
    import socket  # noqa: F401
    import subprocess  # noqa: F401
    import threading  # noqa: F401

    from code_as_monitor.monitor import worker

    worker.validate_program = parse_only
    worker.safe_builtins = lambda: dict(vars(builtins))
    worker.main(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), t0)
