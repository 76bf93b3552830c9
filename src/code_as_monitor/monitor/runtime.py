"""The monitor as the agent sees it: start a program for a subgoal, then one call per frame.

:class:`MonitorRuntime` glues validation, the sandbox and path coverage together::

    rt = MonitorRuntime()
    report = rt.start(source, constraints, elements, history, history_t, t)   # ProgramError -> regenerate
    while ...:
        verdicts = rt.step(elements, history, history_t, t)
        if during_violations(verdicts): halt, re-plan with the reasons
        elif upon_satisfied(verdicts): subgoal complete
    rt.close()

Faults (program errors, overruns, worker restarts) are reported in the verdicts with ``fault=True`` and
never count as violations or satisfactions.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.constraints import Constraint, Phase, Verdict
from code_as_monitor.core.errors import SandboxError
from code_as_monitor.monitor.coverage import CoverageReport, check_path_coverage
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.validate import validate_program


def during_violations(verdicts: list[Verdict]) -> list[Verdict]:
    """The ``during`` verdicts that say the world violates a constraint (faults excluded)."""
    return [v for v in verdicts if v.phase is Phase.DURING and not v.ok and not v.fault]


def any_during_violated(verdicts: list[Verdict]) -> bool:
    """True when some ``during`` check returned False (a fault is not a violation)."""
    return bool(during_violations(verdicts))


def upon_satisfied(verdicts: list[Verdict]) -> bool:
    """True when every ``upon`` check returned True without a fault (vacuously True with none)."""
    return all(v.ok and not v.fault for v in verdicts if v.phase is Phase.UPON)


def unmet_upon(verdicts: list[Verdict]) -> list[Verdict]:
    """``upon`` verdicts that are not satisfied (False or faulted): the reasons of a reactive failure."""
    return [v for v in verdicts if v.phase is Phase.UPON and (not v.ok or v.fault)]


def faults(verdicts: list[Verdict]) -> list[Verdict]:
    """Verdicts where the program itself failed (exception, malformed result, deadline, restart)."""
    return [v for v in verdicts if v.fault]


class MonitorRuntime:
    """One monitor program per subgoal, evaluated in a sandbox every frame.

    Args:
        sandbox: a sandbox to use (not closed by :meth:`close` unless created here); by default one is
            created with ``deadline_s`` and ``memory_mb``.
        deadline_s: per-frame deadline of a new sandbox, seconds.
        memory_mb: memory headroom of a new sandbox's worker, MiB.
        n_perturbations: perturbed inputs of path coverage.
        seed: seed of the perturbations.
        require_full_coverage: False accepts programs with unreached branches.
    """

    def __init__(self, sandbox: Sandbox | None = None, deadline_s: float = 0.020, memory_mb: int = 512,
                 n_perturbations: int = 96, seed: int = 0, require_full_coverage: bool = True) -> None:
        self._own = sandbox is None
        self.sandbox = sandbox if sandbox is not None else Sandbox(deadline_s=deadline_s, memory_mb=memory_mb)
        self.n_perturbations = n_perturbations
        self.seed = seed
        self.require_full_coverage = require_full_coverage
        self.constraints: list[Constraint] = []
        self.source: str | None = None
        self.report: CoverageReport | None = None

    def start(self, source: str, constraints: list[Constraint], elements: dict[int, np.ndarray],
              history: dict[int, np.ndarray] | None = None, history_t: np.ndarray | None = None,
              t: float = 0.0) -> CoverageReport:
        """Accept a program for a new subgoal: validate, path-cover on the current state, load.

        Args:
            source: the generated monitor program.
            constraints: the subgoal's constraints (verdict order).
            elements: element id -> (k, 3) current points, world metres.
            history: element id -> (T, k, 3), oldest first, or None.
            history_t: (T,) seconds, or None.
            t: current time, seconds.
        Returns:
            The path-coverage report.
        Raises:
            ProgramError: rejected statically, by path coverage (a CoverageError) or at load; the
                message is the feedback for regenerating the program. The previous program is dropped.
        """
        self.source, self.constraints, self.report = None, [], None
        validate_program(source, constraints)
        self.sandbox.start()
        report = check_path_coverage(source, constraints, elements, history, history_t, t, self.sandbox,
                                     n_perturbations=self.n_perturbations, seed=self.seed,
                                     require_full_coverage=self.require_full_coverage)
        self.sandbox.load(source, constraints)
        self.source, self.constraints, self.report = source, list(constraints), report
        return report

    def step(self, elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
             history_t: np.ndarray | None, t: float) -> list[Verdict]:
        """Evaluate every check on this frame (one sandbox round trip, never longer than the deadline).

        Args:
            elements: element id -> (k, 3) current points, world metres.
            history: element id -> (T, k, 3), oldest first (e.g. ``ElementHistory.arrays()``), or None.
            history_t: (T,) seconds, or None.
            t: current time, seconds.
        Returns:
            One verdict per constraint, in constraint order.
        """
        if self.source is None:
            raise SandboxError("MonitorRuntime.step called without a started program")
        return self.sandbox.evaluate(elements, history, history_t, t)

    def close(self) -> None:
        """Stop the sandbox worker if this runtime created it."""
        if self._own:
            self.sandbox.close()

    def __enter__(self) -> MonitorRuntime:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
