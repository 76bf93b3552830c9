"""Fixtures for the VLM layer tests: running trusted kb programs on constructed element states."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from code_as_monitor.core import Element, Subgoal
from code_as_monitor.geometry.helpers import MONITOR_HELPERS
from code_as_monitor.planning import legend_specs


class History(dict):
    """``H`` as the sandbox gives it: element id -> history (T, k, 3), with ``H.t`` (T,); built from a list."""

    t: np.ndarray

    def __init__(self, per_element: list[np.ndarray]) -> None:
        super().__init__(enumerate(per_element))


def elements_for(subgoal: Subgoal, points: dict[tuple[str, str], np.ndarray]) -> list[Element]:
    """Legend elements of ``subgoal`` numbered in part order, placed at ``points[(obj, part)]``."""
    out = []
    for i, s in enumerate(legend_specs(subgoal)):
        p = np.asarray(points[(s.obj, s.part)], dtype=float).reshape(-1, 3)
        out.append(Element(i, s.name, s.kind, p, (s.obj, s.part)))
    return out


def history_from(start: list[Element], now: list[Element]) -> list[np.ndarray]:
    """``H`` of two frames per element: where it was at the subgoal's start, and where it is now."""
    return [np.stack([a.points, b.points]) for a, b in zip(start, now)]


def run_checks(source: str, elements: list[Element], history: list[np.ndarray] | None = None,
               t: float = 1.0) -> dict[str, tuple]:
    """Execute every ``check_*`` of ``source`` (trusted kb templates, tests only) on the given state."""
    ns: dict = {"np": np, "math": math, **MONITOR_HELPERS}
    exec(compile(source, "<kb program>", "exec"), ns)
    E = {i: e.points for i, e in enumerate(elements)}
    H = History(history if history is not None else [np.stack([e.points, e.points]) for e in elements])
    H.t = np.array([0.0, t])
    return {name[len("check_"):]: ns[name](E, H, t) for name in ns if name.startswith("check_")}


@pytest.fixture
def run_program() -> Callable[..., dict[str, tuple]]:
    return run_checks


@pytest.fixture
def make_elements() -> Callable[..., list[Element]]:
    return elements_for


@pytest.fixture
def history_of() -> Callable[..., list[np.ndarray]]:
    return history_from
