"""The named ablation settings of Code-as-Monitor: each is a set of :class:`~code_as_monitor.agent.config.MonitorConfig`
fields (the switches live there, with their docstrings; this module only names the combinations the paper's
ablation rows use).

===================  =====================================  ==================================================
name                 MonitorConfig fields                    paper
===================  =====================================  ==================================================
``full``             (defaults)                             Full CaM (MV, CS, CP all on)
``mv-off``           ``cameras=["front"]``                  MV off: the front view only, for painting, prompts
                                                            and tracking
``cs-off``           ``element_source="orb-keypoints"``     CS off (the paper: DINOv2 points; here ORB
                                                            keypoints, lifted and k-means clustered; not DINOv2)
``cp-off``           ``connect_points=False``               CP off: unconnected 3-D points, no lines/surfaces
``reactive-only``    ``checks="reactive"``                  supplementary table, ID D ("Only Reactive")
``proactive-only``   ``checks="proactive"``                 supplementary table, ID C ("Only Proactive")
===================  =====================================  ==================================================
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.core.errors import ConfigError

FRONT_VIEW = "front"
"""The view MV-off keeps (every simulator task has it; a robot's caller names its own with ``cameras``)."""

ABLATIONS: dict[str, dict[str, Any]] = {
    "full": {},
    "mv-off": {"cameras": [FRONT_VIEW]},
    "cs-off": {"element_source": "orb-keypoints"},
    "cp-off": {"connect_points": False},
    "reactive-only": {"checks": "reactive"},
    "proactive-only": {"checks": "proactive"},
}


def ablation_fields(name: str) -> dict[str, Any]:
    """The MonitorConfig fields of ablation ``name`` (a copy); ConfigError naming the known ones otherwise."""
    if not isinstance(name, str) or name not in ABLATIONS:
        raise ConfigError(f"unknown ablation {name!r}; known: {', '.join(ABLATIONS)}")
    return {k: list(v) if isinstance(v, list) else v for k, v in ABLATIONS[name].items()}


__all__ = ["ABLATIONS", "FRONT_VIEW", "ablation_fields"]
