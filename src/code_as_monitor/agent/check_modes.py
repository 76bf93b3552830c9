"""Which of a subgoal's checks the monitor runs: all of them, only the reactive ones or only the proactive ones.

Reactive versus proactive is a property of the constraint, not of its phase (design, "Semantics worth getting
right"): :attr:`Constraint.proactive <code_as_monitor.core.constraints.Constraint.proactive>` is True for a
constraint that *predicts* a failure (the book turned under the approaching jaws will be gripped skewed; the
book low beside the slot will miss it), False for one that *detects* a failure that has happened (the book is
not in the gripper any more; it does not stand in the slot). A reactive constraint may be a ``during`` or an
``upon`` check; so may a proactive one (the kb's are ``during`` checks, and pour-tea's spout-over-the-cup check
at the end of the transport is an ``upon`` one).

``reactive`` keeps the constraints with ``proactive`` False, ``proactive`` those with it True (the ablation
rows "reactive checks only" / "proactive checks only" of the paper's supplementary Table, IDs C and D). A
subgoal left with no check is watched by none: it ends when the policy says it is done, as an open loop's
would (:class:`~code_as_monitor.agent.code_checker.CodeChecker`).
"""

from __future__ import annotations

from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.errors import ConfigError

CHECK_MODES = ("all", "reactive", "proactive")
"""The values of :attr:`AgentConfig.checks <code_as_monitor.agent.config.AgentConfig.checks>`."""


def check_mode(value: object, owner: str = "AgentConfig.checks") -> str:
    """``value`` if it is one of :data:`CHECK_MODES`; ConfigError naming it otherwise."""
    if not isinstance(value, str) or value not in CHECK_MODES:
        raise ConfigError(f"{owner} must be one of {', '.join(CHECK_MODES)}, got {value!r}")
    return value


def kept_constraints(constraints: list[Constraint], mode: str) -> list[Constraint]:
    """The constraints the monitor checks under ``mode`` (same objects, same order)."""
    check_mode(mode)
    if mode == "all":
        return list(constraints)
    want_proactive = mode == "proactive"
    return [c for c in constraints if bool(c.proactive) == want_proactive]


__all__ = ["CHECK_MODES", "check_mode", "kept_constraints"]
