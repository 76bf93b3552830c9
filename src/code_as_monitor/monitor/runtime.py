"""The monitor as the agent sees it: start a program for a subgoal, then one call per frame.

:class:`MonitorRuntime` glues validation, the sandbox and path coverage together::

    rt = MonitorRuntime()
    report = rt.start(source, constraints, elements, history, history_t, t)   # ProgramError -> regenerate
    if report.violated_at_start: halt before starting, re-plan with their reasons
    while ...:
        verdicts = rt.step(elements, history, history_t, t)
        if during_violations(verdicts): halt, re-plan with the reasons
        elif upon_satisfied(verdicts): subgoal complete
    rt.close()

Faults (program errors, overruns, worker restarts) are reported in the verdicts with ``fault=True`` and
never count as violations or satisfactions.

Non-finite input: an element whose current points or history hold NaN or inf is *stale* for that frame,
like an element the tracker lost. It is not shown to the program at all, every check whose constraint
names it gets a fault verdict whose reason starts with ``"stale:"`` (no verdict: neither a violation nor
a satisfaction), and :attr:`MonitorRuntime.stale_elements` lists it so the agent can treat it as it
treats tracker loss. History frames whose time is not finite are dropped; a non-finite ``t`` makes every
element stale.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from code_as_monitor.core.constraints import Constraint, Phase, Verdict
from code_as_monitor.core.errors import SandboxError
from code_as_monitor.monitor.coverage import CoverageReport, check_path_coverage
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.validate import validate_program

log = logging.getLogger(__name__)


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
    """Verdicts where the program itself failed (exception, malformed result, deadline, restart), or that
    had no verdict because an element they read was stale (reason ``"stale: ..."``)."""
    return [v for v in verdicts if v.fault]


def _finite(a: np.ndarray) -> bool:
    return bool(np.isfinite(a).all())


def split_nonfinite(elements: dict[int, np.ndarray], history: dict[int, np.ndarray] | None,
                    history_t: np.ndarray | None, t: float
                    ) -> tuple[set[int], dict[int, np.ndarray], dict[int, np.ndarray] | None, np.ndarray | None]:
    """Find elements with NaN/inf points (now or in their history) and the frame without them.

    Args:
        elements: element id -> (k, 3) current points.
        history: element id -> (T, k, 3), or None.
        history_t: (T,) seconds, or None.
        t: current time, seconds.
    Returns:
        (stale ids, elements without them, history without them and without frames whose time is not
        finite, the matching times). Inputs that are all finite come back as they are.
    """
    if not math.isfinite(t):
        ids = {int(i) for i in elements} | {int(i) for i in (history or {})}
        return ids, {}, ({} if history is not None else None), history_t
    bad = {int(i) for i, p in elements.items() if not _finite(np.asarray(p, dtype=np.float64))}
    if history is not None:
        if history_t is not None:
            ht = np.asarray(history_t, dtype=np.float64).reshape(-1)
            keep = np.isfinite(ht)
            if not keep.all():
                history = {i: np.asarray(h)[keep] for i, h in history.items()}
                history_t = ht[keep]
        bad |= {int(i) for i, h in history.items() if not _finite(np.asarray(h, dtype=np.float64))}
    if not bad:
        return bad, elements, history, history_t
    elements = {i: p for i, p in elements.items() if int(i) not in bad}
    if history is not None:
        history = {i: h for i, h in history.items() if int(i) not in bad}
    return bad, elements, history, history_t


class MonitorRuntime:
    """One monitor program per subgoal, evaluated in a sandbox every frame.

    Args:
        sandbox: a sandbox to use (not closed by :meth:`close` unless created here); by default one is
            created with ``deadline_s`` and ``memory_mb``.
        deadline_s: per-frame deadline of a new sandbox, seconds.
        memory_mb: memory headroom of a new sandbox's worker, MiB.
        n_perturbations: perturbed inputs of path coverage.
        seed: seed of the perturbations.
        require_full_coverage: True rejects programs for unreached branches alone (by default they are
            reported in the coverage report and logged, not rejected).
        reject_failing_at_start: True rejects programs whose ``during`` checks fail on the starting state (by
            default the program is accepted and those verdicts are in the report's ``violated_at_start``: the
            world violates the constraint, the program is not at fault).
        allow_unconfined: run generated code even where the kernel confinement cannot be installed (an
            explicit opt-out, see :class:`~code_as_monitor.monitor.sandbox.Sandbox`).

    Attributes:
        stale_elements: ids of the elements with non-finite points at the last :meth:`step`.
    """

    def __init__(self, sandbox: Sandbox | None = None, deadline_s: float = 0.020, memory_mb: int = 512,
                 n_perturbations: int = 96, seed: int = 0, require_full_coverage: bool = False,
                 allow_unconfined: bool | None = None, reject_failing_at_start: bool = False) -> None:
        self._own = sandbox is None
        # two spares: path coverage and the program itself each take a fresh worker at subgoal start
        self.sandbox = sandbox if sandbox is not None else Sandbox(
            deadline_s=deadline_s, memory_mb=memory_mb, spares=2, allow_unconfined=allow_unconfined)
        self.n_perturbations = n_perturbations
        self.seed = seed
        self.require_full_coverage = require_full_coverage
        self.reject_failing_at_start = reject_failing_at_start
        self.constraints: list[Constraint] = []
        self.source: str | None = None
        self.report: CoverageReport | None = None
        self.stale_elements: set[int] = set()

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
            The path-coverage report; its ``violated_at_start`` are the ``during`` verdicts already False on
            this state (a program that passes coverage but whose constraint the world violates now).
        Raises:
            ProgramError: rejected statically, by path coverage (a CoverageError) or at load; the
                message is the feedback for regenerating the program. The previous program is dropped.
        """
        self.source, self.constraints, self.report = None, [], None
        validate_program(source, constraints)
        self.sandbox.start()
        report = check_path_coverage(source, constraints, elements, history, history_t, t, self.sandbox,
                                     n_perturbations=self.n_perturbations, seed=self.seed,
                                     require_full_coverage=self.require_full_coverage,
                                     reject_failing_at_start=self.reject_failing_at_start)
        if report.unreached:
            log.info("monitor program accepted with %d unreached branch(es): %s", len(report.unreached),
                     "; ".join(b.describe() for b in report.unreached[:5]))
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
            One verdict per constraint, in constraint order. Checks of constraints that name an element
            with non-finite points get a ``"stale: ..."`` fault (see the module docstring).
        """
        if self.source is None:
            raise SandboxError("MonitorRuntime.step called without a started program")
        stale, elements, history, history_t = split_nonfinite(elements, history, history_t, t)
        self.stale_elements = stale
        if not stale:
            return self.sandbox.evaluate(elements, history, history_t, t)
        t_safe = float(t) if math.isfinite(t) else 0.0
        verdicts = self.sandbox.evaluate(elements, history, history_t, t_safe) if elements else []
        by_id = {v.constraint_id: v for v in verdicts}
        out = []
        for c in self.constraints:
            hit = sorted(stale & {int(i) for i in c.element_ids}) if math.isfinite(t) else sorted(stale)
            v = by_id.get(c.id)
            if hit or v is None or (v.fault and "KeyError" in v.reason):  # it read an element left out
                what = f"element(s) {hit or sorted(stale)}" if math.isfinite(t) else "the current time"
                out.append(Verdict(c.id, c.phase, False, f"stale: {what} not finite (NaN or inf); no verdict "
                                   "this frame", math.nan, t, True))
            else:
                out.append(v)
        return out

    def close(self) -> None:
        """Stop the sandbox worker if this runtime created it."""
        if self._own:
            self.sandbox.close()

    def __enter__(self) -> MonitorRuntime:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
