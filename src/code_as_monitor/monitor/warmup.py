"""Run, once and before confinement, everything a monitor program may make the worker import.

numpy imports parts of itself on first use (array printing, error messages, some linalg paths). Once
the seccomp filter is on, nothing can be opened, so a first use inside a program would fail. The worker
therefore calls every allowed numpy, ``math`` and geometry-helper function on a few small inputs, prints
and formats arrays and scalars every way a reason string does, and provokes the common numpy errors,
all in trusted code with the errors swallowed.
"""

from __future__ import annotations

import contextlib
import itertools
from typing import Any

import numpy as np

from code_as_monitor.geometry.helpers import MONITOR_HELPERS
from code_as_monitor.monitor.npsurface import build_math, build_numpy

_SPECS = ("", ".3f", "+.2f", ".1e", ".2%", "8.3f", "g", ",", ".0f", "d", "s", "r")


def _inputs() -> list[Any]:
    a = np.array([[0.0, 1.0, 2.0], [1.0, 0.5, 0.25], [2.0, 1.0, 0.0], [0.5, 0.5, 1.0]])
    return [a, a[0], a[:3], float(a[1, 1]), a[0, 1], 0, 1.0, [1.0, 2.0, 3.0], a > 0.5, a.astype(int),
            np.zeros((5, 4, 3)), np.array([0.0, 1.0, 2.0, 3.0])]


def _format_everything() -> None:
    a = np.array([[0.0, 1.0, 2.0], [1.0, 0.5, 0.25]])
    values: list[Any] = [a, a[0], a > 0, a.astype(int), np.zeros(2000), np.array(1.5), np.array([]),
                         np.array(["a", "b"]), np.array([np.nan, np.inf]), np.float64(1.5), np.float32(1.5),
                         np.int64(3), np.int32(3), np.bool_(True), a.mean(axis=0), 1.5, 3, True]
    for v in values:
        for conv in (str, repr):
            with contextlib.suppress(Exception):
                conv(v)
        for spec in _SPECS:
            with contextlib.suppress(Exception):
                format(v, spec)
        for pattern in ("%s", "%r", "%.3f", "%d", "%5.2f", "%e", "%g"):
            with contextlib.suppress(Exception):
                _ = pattern % (v,)
        with contextlib.suppress(Exception):
            _ = f"{v} {v!r} {v:.2f}"


def _call_everything(namespace: dict[str, Any]) -> None:
    inputs = _inputs()
    for fn in namespace.values():
        if not callable(fn) or isinstance(fn, type):
            continue
        for args in itertools.chain(((x,) for x in inputs), itertools.product(inputs[:4], repeat=2),
                                    ((inputs[0], inputs[0], 0.01),)):
            with contextlib.suppress(Exception):
                fn(*args)


def _provoke_errors() -> None:
    a = np.zeros((3, 3))
    attempts = [
        lambda: a + np.zeros(4), lambda: np.linalg.inv(a), lambda: np.linalg.solve(a, np.zeros(3)),
        lambda: a[5], lambda: np.array([[1.0], [1.0, 2.0]]), lambda: a.reshape(7), lambda: np.mean([]),
        lambda: np.zeros(-1), lambda: np.float64(1) / 0, lambda: np.array([1, 2]).astype("O").view(),
        lambda: np.percentile(a, 200), lambda: np.dot(a, np.zeros(4)), lambda: np.linalg.norm("x"),
        lambda: np.sum(a, axis=3), lambda: np.concatenate([a, np.zeros(2)]),
        lambda: np.argmax(np.array([])), lambda: np.linalg.eig(np.ones((2, 3))), lambda: np.interp(1, [], []),
    ]
    for fn in attempts:
        try:
            fn()
        except Exception as exc:
            str(exc)
            repr(exc)


def warm_up() -> None:
    """Exercise the program namespace once (see the module docstring); never raises."""
    np_ns = build_numpy()
    members: dict[str, Any] = {f"np.{k}": v for k, v in vars(np_ns).items() if not k.startswith("_")}
    members.update({f"np.linalg.{k}": v for k, v in vars(np_ns.linalg).items() if not k.startswith("_")})
    members.update({f"math.{k}": v for k, v in vars(build_math()).items() if not k.startswith("_")})
    members.update(MONITOR_HELPERS)
    with np.errstate(all="ignore"):
        _format_everything()
        _call_everything(members)
        _provoke_errors()
