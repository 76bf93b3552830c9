"""Choice registry for swappable stages.

Every swappable stage (segmenter, tracker, VLM backend, executor, baseline, task, disturbance) has a
config base class that derives from :class:`Choice`. Each backend registers its config dataclass by
name, and the CLI or Python picks it by that name::

    @dataclass
    class TrackerConfig(Choice):
        ...

    @TrackerConfig.register("lk")
    @dataclass
    class LKTrackerConfig(TrackerConfig):
        window: int = 21

    cfg = TrackerConfig.from_name("lk", window=15)

Implementations are imported lazily by the factory that builds them from a config, so importing a
config module never imports an optional dependency.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any, ClassVar, TypeVar

from code_as_monitor.core.checks import check_fields, check_positive, check_probability
from code_as_monitor.core.errors import ConfigError, UnknownChoiceError

__all__ = ["Choice", "build_lazily", "check_positive", "check_probability"]

C = TypeVar("C", bound="Choice")


class Choice:
    """Base of every registered config. Subclass once per stage, then register backends on it."""

    _registry: ClassVar[dict[str, type[Choice]]]
    name: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # A direct subclass of Choice is a stage: it owns a fresh registry.
        if Choice in cls.__bases__:
            cls._registry = {}

    @classmethod
    def register(cls, name: str):
        """Class decorator registering a config subclass under ``name`` on this stage."""

        def deco(sub: type[C]) -> type[C]:
            if not issubclass(sub, cls):
                raise ConfigError(f"{sub.__name__} does not derive from {cls.__name__}")
            if name in cls._registry and cls._registry[name] is not sub:
                raise ConfigError(f"{cls.__name__}: name {name!r} is already registered")
            sub.name = name
            cls._registry[name] = sub
            return sub

        return deco

    @classmethod
    def choices(cls) -> list[str]:
        """Registered names, sorted."""
        return sorted(cls._registry)

    @classmethod
    def get_class(cls: type[C], name: str) -> type[C]:
        """The config class registered as ``name``; raises :class:`UnknownChoiceError` naming the choices."""
        try:
            return cls._registry[name]  # type: ignore[return-value]
        except KeyError:
            raise UnknownChoiceError(
                f"unknown {cls.__name__} {name!r}; choose one of: {', '.join(cls.choices()) or '(none)'}"
            ) from None

    @classmethod
    def from_name(cls: type[C], name: str, **kwargs: Any) -> C:
        """Build the config registered as ``name`` with ``kwargs``; unknown fields, and values of the
        wrong type for plain ``float``/``int``/``str``/``bool`` fields (a string for a number, NaN, inf),
        are a ConfigError naming the field and the value."""
        sub = cls.get_class(name)
        if dataclasses.is_dataclass(sub):
            fields = {f.name for f in dataclasses.fields(sub)}
            bad = sorted(set(kwargs) - fields)
            if bad:
                raise ConfigError(
                    f"{name}: unknown option(s) {', '.join(bad)}; known: {', '.join(sorted(fields))}"
                )
            check_fields(name, sub, kwargs)
        return sub(**kwargs)

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dict of the config, with its registered name under ``"name"``."""
        out: dict[str, Any] = {"name": type(self).name}
        if dataclasses.is_dataclass(self):
            out.update(dataclasses.asdict(self))
        return out


def build_lazily(implementations: dict[str, str], config: Choice, stage: str) -> Any:
    """Instantiate the implementation of ``config`` from ``implementations`` (name -> "module:Class"),
    importing its module only now, so a missing optional dependency fails only for the user who chose it."""
    name = type(config).name
    if name not in implementations:
        raise ConfigError(f"no {stage} implementation registered for {name!r}")
    module, cls = implementations[name].split(":")
    return getattr(importlib.import_module(module), cls)(config)
