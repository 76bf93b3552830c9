"""Monitor-code templates for the ``open-drawer`` constraints.

Same rules as :mod:`code_as_monitor.vlm.kb.templates`.
"""

from __future__ import annotations

from collections.abc import Callable

from code_as_monitor.vlm.kb.templates import Spec

DRAWER_TEMPLATES: dict[str, Callable[[Spec], str]] = {}
"""Template key (constraint id prefix) -> writer, for the ``open-drawer`` constraints."""
