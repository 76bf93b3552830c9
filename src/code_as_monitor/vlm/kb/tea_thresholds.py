"""The knowledge base's thresholds for ``pour-tea``.

Merged into :data:`code_as_monitor.vlm.kb.thresholds.THRESHOLDS`.

Physical tolerances from the object sizes in sim/assets, never fitted to evaluation outcomes. Units: metres,
radians, fractions.
"""

from __future__ import annotations

TEA_THRESHOLDS: dict[str, dict[str, float]] = {}
