"""What ``np`` and ``math`` are inside a monitor program: allow-listed proxies, built in the worker.

The static validator already refuses any ``np.<name>`` outside :data:`.allowlist.NP_ALLOWED`; these
proxies make the same list hold at run time (a second layer): ``np`` is a fresh module object holding
only the allowed members, ``np.linalg`` likewise, and

* ``np.ndarray`` works with ``isinstance`` but cannot be called (the constructor builds arrays over a
  given buffer with given strides);
* every allowed function is wrapped: no ``out=`` argument, a ``dtype=`` only from
  :data:`ALLOWED_DTYPES`, and a result that is an array of objects, void/structured records, bytes or
  datetimes is refused (:data:`ALLOWED_KINDS`).

Nothing here builds an array over a buffer, and no member exposes ``ctypes``, ``lib``, ``f2py`` or stride
tricks.
"""

from __future__ import annotations

import contextlib
import functools
import math
import types
from collections.abc import Callable
from typing import Any

import numpy as np

from code_as_monitor.monitor.allowlist import MATH_ALLOWED, NP_ALLOWED, NP_LINALG_ALLOWED

ALLOWED_KINDS = frozenset("biufcU")
"""dtype kinds a program's arrays may have: bool, integers, floats, complex, text."""

_DTYPE_NAMES = ("float", "float64", "float32", "f8", "f4", "int", "int64", "int32", "i8", "i4", "bool",
                "bool_", "?", "b1", "complex", "complex128")

def _dtypes() -> frozenset[Any]:
    out: set[Any] = {None, float, int, bool, complex, np.float64, np.float32, np.int64, np.int32, np.bool_,
                     np.complex128, *_DTYPE_NAMES}
    for n in _DTYPE_NAMES:
        with contextlib.suppress(TypeError):
            out.add(np.dtype(n))
    return frozenset(out)


ALLOWED_DTYPES: frozenset[Any] = _dtypes()
"""What a ``dtype=`` argument may be."""


class _NdarrayMeta(type):
    def __instancecheck__(cls, obj: object) -> bool:
        return isinstance(obj, np.ndarray)

    def __subclasscheck__(cls, sub: type) -> bool:
        return issubclass(sub, np.ndarray)


class NdarrayType(metaclass=_NdarrayMeta):
    """``np.ndarray`` in a program: ``isinstance(x, np.ndarray)`` works, calling it does not."""

    def __new__(cls, *args: Any, **kwargs: Any) -> NdarrayType:
        raise TypeError("np.ndarray(...) cannot be called in a monitor program; use np.array or np.zeros")


def check_dtype(dtype: Any) -> None:
    """Raise TypeError unless ``dtype`` is one of :data:`ALLOWED_DTYPES`."""
    try:
        ok = dtype in ALLOWED_DTYPES
    except TypeError:  # unhashable
        ok = False
    if not ok:
        raise TypeError(f"dtype {dtype!r} is not allowed in a monitor program (use float, int or bool)")


def check_result(name: str, value: Any) -> Any:
    """Refuse arrays of objects, records, bytes or datetimes (alone or in a tuple); return ``value``."""
    if type(value) is np.ndarray:
        if value.dtype.kind not in ALLOWED_KINDS:
            raise TypeError(f"np.{name} made an array of dtype {value.dtype.str!r}, which a monitor "
                            "program may not use (numbers, bools and text only)")
    elif isinstance(value, tuple):
        for v in value:
            if type(v) is np.ndarray and v.dtype.kind not in ALLOWED_KINDS:
                raise TypeError(f"np.{name} made an array of dtype {v.dtype.str!r}, which a monitor "
                                "program may not use")
    return value


def guard(fn: Callable[..., Any], name: str) -> Callable[..., Any]:
    """``fn`` with the argument and result checks of the module docstring."""

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        if kwargs:
            if "out" in kwargs:
                raise TypeError(f"np.{name}: 'out=' is not allowed in a monitor program")
            if "dtype" in kwargs:
                check_dtype(kwargs["dtype"])
        return check_result(name, fn(*args, **kwargs))

    return call


def _module(name: str, doc: str, members: dict[str, Any]) -> types.ModuleType:
    m = types.ModuleType(name, doc)
    for k, v in members.items():
        setattr(m, k, v)
    return m


def build_numpy() -> types.ModuleType:
    """The ``np`` a program sees: only :data:`NP_ALLOWED`, functions guarded, ``np.linalg`` restricted."""
    linalg = _module("np.linalg", "numpy.linalg, restricted",
                     {n: guard(getattr(np.linalg, n), f"linalg.{n}") for n in sorted(NP_LINALG_ALLOWED)})
    members: dict[str, Any] = {}
    for n in sorted(NP_ALLOWED):
        obj = getattr(np, n)
        if n == "linalg":
            obj = linalg
        elif n == "ndarray":
            obj = NdarrayType
        elif isinstance(obj, type) or not callable(obj):
            pass  # scalar types (np.float64(x) builds one number) and constants
        else:
            obj = guard(obj, n)
        members[n] = obj
    return _module("np", "numpy, restricted to what monitor programs may use", members)


def build_math() -> types.ModuleType:
    """The ``math`` a program sees: only :data:`MATH_ALLOWED`."""
    return _module("math", "math, restricted", {n: getattr(math, n) for n in sorted(MATH_ALLOWED)})
