"""Choice registry: registration, lookup by name, errors naming the bad value and the choices."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from code_as_monitor.core.errors import ConfigError, UnknownChoiceError
from code_as_monitor.core.registry import Choice, check_positive, check_probability


@dataclass
class FilterConfig(Choice):
    pass


@FilterConfig.register("median")
@dataclass
class MedianConfig(FilterConfig):
    window: int = 3


@FilterConfig.register("mean")
@dataclass
class MeanConfig(FilterConfig):
    pass


@dataclass
class OtherStage(Choice):
    pass


def test_from_name_and_to_dict() -> None:
    cfg = FilterConfig.from_name("median", window=5)
    assert isinstance(cfg, MedianConfig) and cfg.window == 5
    assert cfg.to_dict() == {"name": "median", "window": 5}
    assert FilterConfig.choices() == ["mean", "median"]
    assert OtherStage.choices() == []  # each stage owns its registry


def test_unknown_name_lists_the_choices() -> None:
    with pytest.raises(UnknownChoiceError, match="unknown FilterConfig 'mode'; choose one of: mean, median") as e:
        FilterConfig.from_name("mode")
    assert str(e.value).startswith("unknown")  # not a quoted KeyError message
    with pytest.raises(UnknownChoiceError, match=r"\(none\)"):
        OtherStage.get_class("x")


def test_unknown_option_names_it_and_the_known_fields() -> None:
    with pytest.raises(ConfigError, match=r"median: unknown option.*size; known: window"):
        FilterConfig.from_name("median", size=3)


def test_registration_errors() -> None:
    with pytest.raises(ConfigError, match="already registered"):

        @FilterConfig.register("mean")
        @dataclass
        class Another(FilterConfig):
            pass

    with pytest.raises(ConfigError, match="does not derive from FilterConfig"):
        FilterConfig.register("other")(OtherStage)


def test_value_checks_name_the_field() -> None:
    check_positive("Tracker", "window", 3)
    check_positive("Tracker", "delay", 0, allow_zero=True)
    with pytest.raises(ConfigError, match=r"Tracker.window must be > 0, got -1"):
        check_positive("Tracker", "window", -1)
    with pytest.raises(ConfigError, match=r"Noise.p must be in \[0, 1\], got 1.5"):
        check_probability("Noise", "p", 1.5)
