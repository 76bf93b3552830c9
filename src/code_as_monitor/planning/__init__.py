"""planning layer: the constraint generator and the monitor coder, on top of any VLM backend."""

from code_as_monitor.planning.coder import (
    MonitorCoder,
    basic_check,
    legend_specs,
    program_defines_checks,
    resolve_element_ids,
)
from code_as_monitor.planning.generator import SUCCESS_FEEDBACK, ConstraintGenerator

__all__ = [
    "SUCCESS_FEEDBACK",
    "ConstraintGenerator",
    "MonitorCoder",
    "basic_check",
    "legend_specs",
    "program_defines_checks",
    "resolve_element_ids",
]
