"""Monitor programs: static validation, the sandbox worker, path coverage and per-frame evaluation.

Generated code is untrusted: it is checked against an AST allow-list (:mod:`.validate`) and only ever
compiled and run in a separate, resource-limited worker process (:mod:`.sandbox`, :mod:`.worker`).
"""

from code_as_monitor.monitor.coverage import CoverageError, CoverageReport, check_path_coverage
from code_as_monitor.monitor.runtime import (
    MonitorRuntime,
    any_during_violated,
    during_violations,
    faults,
    unmet_upon,
    upon_satisfied,
)
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.validate import validate_program

__all__ = [
    "CoverageError",
    "CoverageReport",
    "MonitorRuntime",
    "Sandbox",
    "any_during_violated",
    "check_path_coverage",
    "during_violations",
    "faults",
    "unmet_upon",
    "upon_satisfied",
    "validate_program",
]
