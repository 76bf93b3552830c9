"""The kb's task families, loaded by name, and the tables merged from them (thresholds, templates).

Adding a task family: write ``families/<name>.py`` ending in ``FAMILY = TaskFamily(...)`` (see
:class:`~code_as_monitor.vlm.kb.family.TaskFamily`) and add ``"<name>"`` to :data:`FAMILY_MODULES`. Families
are asked in this order; the first whose ``understand`` returns a goal plans the instruction.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from functools import cache

from code_as_monitor.vlm.kb.family import TaskFamily
from code_as_monitor.vlm.kb.shared import codegen, grip
from code_as_monitor.vlm.kb.shared.codegen import Template

FAMILY_MODULES: tuple[str, ...] = (
    "rope",
    "dustpan",  # before "sweep": sweeping into a dustpan is its own task
    "sweep",
    "pen",
    "book",
    "tea",
    "putdrawer",  # before "drawer": "open the drawer and put ... in it" is more than opening it
    "drawer",
    "bulb",
    "tap",
    "drag",
    "stack",
)
"""Module names under ``code_as_monitor.vlm.kb.families``: one line per task family."""

SHARED_TEMPLATES: tuple[Mapping[str, Template], ...] = (codegen.TEMPLATES, grip.TEMPLATES)
"""Templates several families use (tilt checks, the grasp checks)."""


@cache
def families() -> tuple[TaskFamily, ...]:
    """Every registered family, in asking order (imported on first use)."""
    out = []
    for name in FAMILY_MODULES:
        fam = importlib.import_module(f"code_as_monitor.vlm.kb.families.{name}").FAMILY
        if not isinstance(fam, TaskFamily):
            raise TypeError(f"kb family module {name!r}: FAMILY is not a TaskFamily")
        out.append(fam)
    names = [f.name for f in out]
    if len(set(names)) != len(names):
        raise ValueError(f"kb family names repeat: {names}")
    return tuple(out)


def _merge(tables: list[tuple[str, Mapping]], what: str) -> dict:
    merged: dict = {}
    owner: dict[str, str] = {}
    for source, table in tables:
        for key, value in table.items():
            if key in merged:
                raise ValueError(f"kb {what} {key!r} defined twice: by {owner[key]} and {source}")
            merged[key], owner[key] = value, source
    return merged


@cache
def all_thresholds() -> dict[str, dict[str, float]]:
    """Constraint kind -> thresholds, over every family (the paper's "knowledge base" of thresholds)."""
    return _merge([(f.name, f.thresholds) for f in families()], "threshold kind")


@cache
def all_templates() -> dict[str, Template]:
    """Template key -> writer, over the shared templates and every family."""
    tables = [("shared", t) for t in SHARED_TEMPLATES] + [(f.name, f.templates) for f in families()]
    return _merge(tables, "template key")


def all_keywords() -> tuple[tuple[str, str], ...]:
    """(word in a constraint's text, template key) fallbacks, families first, then the shared ones."""
    return tuple(k for f in families() for k in f.keywords) + codegen.KEYWORDS


def family(name: str) -> TaskFamily:
    """The family called ``name`` (KeyError naming the families otherwise)."""
    for f in families():
        if f.name == name:
            return f
    raise KeyError(f"no kb task family {name!r}; families: {', '.join(f.name for f in families())}")
