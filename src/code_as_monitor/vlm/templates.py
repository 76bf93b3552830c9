"""Versioned prompt templates stored as package files under ``vlm/prompts/``.

A template is ``<name>.<version>.md``; placeholders are ``{{key}}``. Rendering fails loudly on a
missing or an unused value, so a prompt never goes out half-filled.
"""

from __future__ import annotations

import re
from functools import lru_cache
from importlib import resources

from code_as_monitor.core.errors import ConfigError

PROMPT_VERSION = "v5"
_PLACEHOLDER = re.compile(r"\{\{([a-z_]+)\}\}")


@lru_cache(maxsize=32)
def load_template(name: str, version: str = PROMPT_VERSION) -> str:
    """The raw text of template ``name`` at ``version``."""
    fname = f"{name}.{version}.md"
    try:
        return resources.files("code_as_monitor.vlm").joinpath("prompts", fname).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"prompt template {fname!r} not found in code_as_monitor/vlm/prompts") from None


def placeholders(name: str, version: str = PROMPT_VERSION) -> set[str]:
    """The ``{{key}}`` names template ``name`` expects."""
    return set(_PLACEHOLDER.findall(load_template(name, version)))


def render(name: str, version: str = PROMPT_VERSION, **values: str) -> str:
    """Fill template ``name``; every placeholder must get a value and every value a placeholder."""
    text = load_template(name, version)
    wanted = placeholders(name, version)
    missing = sorted(wanted - set(values))
    extra = sorted(set(values) - wanted)
    if missing or extra:
        raise ConfigError(f"prompt {name}.{version}: missing values {missing}, unexpected values {extra}")
    return _PLACEHOLDER.sub(lambda m: str(values[m.group(1)]), text)
