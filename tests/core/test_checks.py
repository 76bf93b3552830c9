"""Value checks: a bad number is a ConfigError naming owner.field and the value, never a pass."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from code_as_monitor.core.checks import (
    SEED_MAX,
    check_count,
    check_fields,
    check_number,
    check_positive,
    check_probability,
    check_range,
    check_seed,
)
from code_as_monitor.core.errors import ConfigError


@pytest.mark.parametrize("value", ["abc", "1", None, True, [1], math.nan, math.inf, -math.inf])
def test_non_numbers_and_non_finite_are_refused(value) -> None:
    with pytest.raises(ConfigError, match=r"task\.p must be"):
        check_number("task", "p", value)


def test_numbers_pass_through_as_float() -> None:
    assert check_number("o", "f", 3) == 3.0 and check_number("o", "f", np.float32(0.5)) == 0.5


@pytest.mark.parametrize(("check", "value"), [
    (lambda v: check_positive("o", "f", v), 0.0),
    (lambda v: check_positive("o", "f", v), math.inf),
    (lambda v: check_positive("o", "f", v, allow_zero=True), -1e-9),
    (lambda v: check_probability("o", "f", v), 1.0001),
    (lambda v: check_probability("o", "f", v), math.nan),
    (lambda v: check_count("o", "f", v), 0),
    (lambda v: check_count("o", "f", v), 1.5),
    (lambda v: check_count("o", "f", v), 2.0),  # a count is an integer, not an integral float
    (lambda v: check_seed("o", v), -1),
    (lambda v: check_seed("o", v), SEED_MAX + 1),
    (lambda v: check_range("o", "f", v, 0, 10), 11),
])
def test_out_of_range_values_are_refused_with_the_value(check, value) -> None:
    with pytest.raises(ConfigError, match=r"o\.f|o\.seed") as err:
        check(value)
    assert repr(value) in str(err.value) or str(value) in str(err.value)


def test_good_values() -> None:
    check_positive("o", "f", 1e-9)
    check_positive("o", "f", 0, allow_zero=True)
    check_probability("o", "f", 0)
    assert check_count("o", "f", np.int64(3)) == 3 and check_seed("o", SEED_MAX) == SEED_MAX


@dataclass
class _Cfg:
    x: float = 1.0
    n: int = 2
    name: str = "a"
    flag: bool = False
    maybe: float | None = None
    items: list[int] | None = None


@pytest.mark.parametrize(("field", "value", "needle"), [
    ("x", "abc", "must be a number"), ("x", math.nan, "finite"), ("x", True, "must be a number"),
    ("n", 2.5, "integer"), ("name", 3, "must be a str"), ("flag", 1, "must be a bool"),
    ("maybe", "1", "must be a number"), ("x", None, "null"),
])
def test_check_fields_follows_the_annotations(field, value, needle) -> None:
    with pytest.raises(ConfigError, match=needle):
        check_fields("cfg", _Cfg, {field: value})


def test_check_fields_accepts_the_right_types_and_skips_containers() -> None:
    check_fields("cfg", _Cfg, {"x": 2, "n": 3, "name": "b", "flag": True, "maybe": None, "items": "not checked"})


def test_library_configs_name_the_bad_value() -> None:
    from code_as_monitor.bench.episode import EpisodeOptions
    from code_as_monitor.bench.executors import LocalExecutorConfig
    from code_as_monitor.bench.protocol import BenchSpec

    with pytest.raises(ConfigError, match=r"BenchSpec\.episodes must be >= 1, got 0"):
        BenchSpec(seeds=1, episodes=0)
    with pytest.raises(ConfigError, match=r"EpisodeOptions\.doremi_k_s"):
        EpisodeOptions(doremi_k_s=math.nan)
    with pytest.raises(ConfigError, match=r"EpisodeOptions\.camera_hz must be a number, got 'fast'"):
        EpisodeOptions(camera_hz="fast")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"workers"):
        LocalExecutorConfig(workers=-2)


def test_negative_seeds_are_refused_by_the_library_before_a_world_exists() -> None:
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig

    with pytest.raises(ConfigError, match=r"ClosedLoopConfig\.seed must be in \[0, 4294967295\], got -1"):
        ClosedLoopConfig(seed=-1)
    pytest.importorskip("pybullet")
    from code_as_monitor.sim.env import make_env

    with pytest.raises(ConfigError, match=r"World\.seed"):
        make_env("stack-in-order", seed=-1)
