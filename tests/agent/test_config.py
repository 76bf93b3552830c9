"""MonitorConfig's explicit opt-out of the sandbox's kernel confinement (issue 13: a named config field)."""

from __future__ import annotations

import pytest

from code_as_monitor.agent import build
from code_as_monitor.agent.config import MonitorConfig
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.monitor import runtime


def test_allow_unconfined_is_off_by_default_and_must_be_a_bool():
    assert MonitorConfig().allow_unconfined is False
    with pytest.raises(ConfigError, match=r"allow_unconfined.*'yes'"):
        MonitorConfig(allow_unconfined="yes")  # type: ignore[arg-type]


@pytest.mark.parametrize(("field", "passed"), [(False, None), (True, True)])
def test_the_field_reaches_the_sandbox_runtime(monkeypatch, field, passed):
    seen = {}

    class Runtime:
        def __init__(self, **kw):
            seen.update(kw)

    monkeypatch.setattr(runtime, "MonitorRuntime", Runtime)
    build.build_stages(MonitorConfig(allow_unconfined=field, tracker="sim"))
    # None (not False) when off: the CAM_ALLOW_UNCONFINED environment variable still decides then
    assert seen["allow_unconfined"] is passed
