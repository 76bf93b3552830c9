"""The named ablation settings are MonitorConfig fields (the switches), and every name builds a valid config."""

from __future__ import annotations

import dataclasses

import pytest

from code_as_monitor.agent.ablations import ABLATIONS, ablation_fields
from code_as_monitor.agent.config import MonitorConfig
from code_as_monitor.core.errors import ConfigError


@pytest.mark.parametrize("name", sorted(ABLATIONS))
def test_every_setting_is_made_of_monitor_config_fields(name: str) -> None:
    fields = {f.name for f in dataclasses.fields(MonitorConfig)}
    assert set(ablation_fields(name)) <= fields
    cfg = MonitorConfig(**ablation_fields(name))
    for k, v in ablation_fields(name).items():
        assert getattr(cfg, k) == v


def test_the_settings_differ_from_the_full_method_in_exactly_their_switch() -> None:
    full = MonitorConfig()
    assert MonitorConfig(**ablation_fields("mv-off")).cameras == ["front"] and full.cameras is None
    assert MonitorConfig(**ablation_fields("cs-off")).element_source == "orb-keypoints"
    assert full.element_source == "part-masks"
    assert MonitorConfig(**ablation_fields("cp-off")).connect_points is False and full.connect_points is True
    assert MonitorConfig(**ablation_fields("reactive-only")).checks == "reactive" and full.checks == "all"
    assert MonitorConfig(**ablation_fields("proactive-only")).checks == "proactive"


def test_an_unknown_name_or_a_bad_field_value_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="unknown ablation 'dino'"):
        ablation_fields("dino")
    with pytest.raises(ConfigError, match="element_source"):
        MonitorConfig(element_source="dinov2")
    with pytest.raises(ConfigError, match="connect_points"):
        MonitorConfig(connect_points="no")  # type: ignore[arg-type]
    ablation_fields("mv-off")["cameras"].append("top")
    assert ABLATIONS["mv-off"]["cameras"] == ["front"], "a copy is handed out"
