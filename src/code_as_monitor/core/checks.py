"""Value checks shared by every config: numbers, seeds and typed config fields.

Each check raises :class:`~code_as_monitor.core.errors.ConfigError` whose message names the owner,
the field and the offending value (``"stack-in-order.p must be a number, got 'abc'"``), so the CLI
can print it as its one line. A number is a real ``int`` or ``float`` (never a ``bool`` or a string)
and finite: NaN and inf are refused everywhere unless a check says otherwise.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing
from typing import Any, Union

from code_as_monitor.core.errors import ConfigError

SEED_MAX = 2**32 - 1
"""Largest episode seed (numpy seeds are unsigned 32-bit words here; bigger ones are refused, not wrapped)."""

RATE_HZ_RANGE = (0.01, 1000.0)
"""Camera / monitoring rates a run accepts, Hz: below one frame per 100 s or above 1 kHz is a typo, and the
extremes overflow (``1 / 1e-320`` is inf) or make a video encoder refuse the frame rate."""

DEADLINE_S_RANGE = (0.001, 600.0)
"""Per-frame sandbox deadlines accepted, seconds (beyond 600 s the OS timeout overflows; below 1 ms no
round trip to a worker can finish)."""

SIM_CONTROL_HZ = 40
"""The simulator's default control rate (``WorldConfig.control_hz``); its cameras render at most once a tick."""

IMAGE_SIDE_RANGE = (32, 4096)
"""Image width / height accepted by the simulator's cameras, pixels."""


def _name(owner: str, field: str) -> str:
    return f"{owner}.{field}" if owner else field


def check_number(owner: str, field: str, value: Any, *, integer: bool = False, finite: bool = True) -> float:
    """Return ``value`` as a float after checking that it is a real (finite) number.

    Raises ConfigError naming ``owner.field`` for strings, bools, None, NaN, inf (when ``finite``), and
    non-integers when ``integer``.
    """
    is_num = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not is_num:
        kind = "an integer" if integer else "a number"
        raise ConfigError(f"{_name(owner, field)} must be {kind}, got {value!r}")
    f = float(value)
    if math.isnan(f) or (finite and math.isinf(f)):
        raise ConfigError(f"{_name(owner, field)} must be a finite number, got {value!r}")
    if integer and not isinstance(value, numbers.Integral):
        raise ConfigError(f"{_name(owner, field)} must be an integer, got {value!r}")
    return f


def check_range(owner: str, field: str, value: Any, lo: float | None = None, hi: float | None = None,
                *, integer: bool = False, lo_open: bool = False) -> float:
    """Check ``value`` is a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``); returns it as float."""
    f = check_number(owner, field, value, integer=integer)
    low_bad = lo is not None and (f <= lo if lo_open else f < lo)
    if low_bad or (hi is not None and f > hi):
        left = "(" if lo_open else "["
        lo_s = "-inf" if lo is None else _fmt(lo)
        hi_s = "inf" if hi is None else _fmt(hi)
        bound = (f"> {lo_s}" if lo_open else f">= {lo_s}") if hi is None else f"in {left}{lo_s}, {hi_s}]"
        raise ConfigError(f"{_name(owner, field)} must be {bound}, got {value!r}")
    return f


def _fmt(x: float) -> str:
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def check_positive(owner: str, field: str, value: Any, allow_zero: bool = False) -> None:
    """Raise ConfigError naming ``owner.field`` unless ``value`` is a finite number > 0 (>= 0 with ``allow_zero``)."""
    check_range(owner, field, value, 0.0, None, lo_open=not allow_zero)


def check_probability(owner: str, field: str, value: Any) -> None:
    """Raise ConfigError naming ``owner.field`` unless ``value`` is a number in [0, 1]."""
    check_range(owner, field, value, 0.0, 1.0)


def check_count(owner: str, field: str, value: Any, minimum: int = 1) -> int:
    """An integer count ``>= minimum`` (episodes, seeds, workers, retries); returns it as int."""
    return int(check_range(owner, field, value, minimum, None, integer=True))


def check_seed(owner: str, value: Any) -> int:
    """An episode seed: an integer in ``[0, SEED_MAX]``; returns it as int."""
    return int(check_range(owner, "seed", value, 0, SEED_MAX, integer=True))


def _simple_types(annotation: Any) -> tuple[type, ...] | None:
    """The plain types (float, int, str, bool) an annotation allows, plus NoneType for Optional;
    None when the annotation is anything else (containers, literals, classes): such fields are left
    to the config's own ``__post_init__``."""
    origin = typing.get_origin(annotation)
    if origin in (Union, types.UnionType):
        out: list[type] = []
        for a in typing.get_args(annotation):
            if a is type(None):
                out.append(type(None))
                continue
            sub = _simple_types(a)
            if sub is None:
                return None
            out.extend(sub)
        return tuple(out)
    if annotation in (float, int, str, bool):
        return (annotation,)
    return None


def check_fields(owner: str, cls: type, values: dict[str, Any]) -> None:
    """Check ``values`` (field -> value) against the plain annotations of dataclass ``cls``.

    ``float`` fields take finite ints or floats, ``int`` fields integers, ``bool`` fields bools,
    ``str`` fields strings, ``X | None`` also None. Other annotations are not checked here.
    """
    if not dataclasses.is_dataclass(cls):
        return
    try:
        hints = typing.get_type_hints(cls)
    except Exception:  # an annotation that cannot be resolved: leave it to the config itself
        return
    for key, val in values.items():
        allowed = _simple_types(hints.get(key))
        if allowed is None:
            continue
        if val is None:
            if type(None) not in allowed:
                raise ConfigError(f"{_name(owner, key)} must not be empty (null), got None")
            continue
        if bool in allowed and isinstance(val, bool):
            continue
        if float in allowed:
            check_number(owner, key, val)
            continue
        if int in allowed:
            check_number(owner, key, val, integer=True)
            continue
        if str in allowed and isinstance(val, str):
            continue
        want = " or ".join(t.__name__ for t in allowed if t is not type(None))
        raise ConfigError(f"{_name(owner, key)} must be a {want}, got {val!r}")


__all__ = ["DEADLINE_S_RANGE", "IMAGE_SIDE_RANGE", "RATE_HZ_RANGE", "SEED_MAX", "SIM_CONTROL_HZ", "check_count",
           "check_fields", "check_number", "check_positive", "check_probability", "check_range", "check_seed"]
