"""White-box path coverage of a monitor program at subgoal start (paper, supplementary).

:func:`check_path_coverage` loads the branch-instrumented program into a sandbox worker (never into
this process), evaluates it on the current element state and on perturbations of it
(:func:`~code_as_monitor.monitor.perturb.make_probes`), and collects

* checks that raise, return a malformed result or overrun the deadline, with the input that did it;
* checks whose answer never changes: True on every input (they can never report a violation) or
  False on every input (they can never be satisfied);
* ``during`` checks that already fail on the unperturbed starting state;
* branches no input reaches (with their lines).

Either of the first two raises :class:`CoverageError` (a :class:`~code_as_monitor.core.errors.ProgramError`)
whose message goes back to the coder for a bounded number of regenerations. Unreached branches alone
do not: a defensive guard (``if pts.shape[0] < 3: return False, ...``) that no perturbation reaches is
reported in :attr:`CoverageReport.unreached`, not rejected (unless ``require_full_coverage``).

A ``during`` check that returns False on the starting state but True on some perturbation of it is a
program that works, on a world that already violates its constraint (the paper regenerates code when
testing finds an *error*; a violated constraint is not one). It is accepted and its verdict is kept in
:attr:`CoverageReport.violated_at_start`, for the agent to raise as an alarm at once, so that the planner
re-plans on the violation instead of the coder being asked for another program. A check that is False on
every input can never be satisfied and is still rejected (a constant answer);
``reject_failing_at_start=True`` restores the stricter rule that rejects the program.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from code_as_monitor.core.constraints import Constraint, Phase, Verdict
from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.instrument import Branch, instrument
from code_as_monitor.monitor.perturb import make_probes
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.monitor.validate import validate_program

MAX_LISTED = 12
MAX_OVERRUNS = 2
MIN_PROBE_DEADLINE_S = 0.5
"""Least time one coverage input may take. Coverage is not real-time, and a program rejected because a busy
machine delayed one of its inputs is a false rejection: at 100 ms that happened under load average 17 (a
drawer program, three checks, in the test suite). A program that never answers still costs at most
``MAX_OVERRUNS`` of these."""


@dataclass
class CoverageReport:
    """What path coverage found.

    Attributes:
        branches: the branch table of the instrumented program.
        covered: ids of the branches some input reached.
        n_inputs: how many inputs were evaluated (the current state, the perturbations and the turning
            histories of line and surface elements).
        faults: "check: reason (on input)" for every distinct exception / malformed result / overrun.
        unreached: the branches no input reached (in functions that were entered at least once).
        failing_at_start: "check: reason" of ``during`` checks already violated on the starting state.
        violated_at_start: their verdicts on the starting state (constraint order): violations of the world
            that the agent reports at once; they reject the program only with ``reject_failing_at_start``.
        reject_failing_at_start: whether ``failing_at_start`` rejects the program (the stricter setting).
        outcomes: check function name -> (times it returned True, times False), faults not counted.
        constant: "check: ..." of checks that returned the same answer on every input.
    """

    branches: list[Branch]
    covered: set[int] = field(default_factory=set)
    n_inputs: int = 0
    faults: list[str] = field(default_factory=list)
    unreached: list[Branch] = field(default_factory=list)
    failing_at_start: list[str] = field(default_factory=list)
    violated_at_start: list[Verdict] = field(default_factory=list)
    reject_failing_at_start: bool = False
    outcomes: dict[str, tuple[int, int]] = field(default_factory=dict)
    constant: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Nothing that rejects the program (unreached branches are only reported)."""
        return not (self.faults or self.constant or (self.reject_failing_at_start and self.failing_at_start))

    @property
    def fraction(self) -> float:
        """Covered share of the branches (1.0 for a program without branches)."""
        return len(self.covered) / len(self.branches) if self.branches else 1.0

    def message(self) -> str:
        """The feedback for the coder: every problem, most important first."""
        lines: list[str] = []
        if self.faults:
            lines.append("the program fails on some inputs:")
            lines += [f"  - {f}" for f in self.faults[:MAX_LISTED]]
        if self.constant:
            lines.append("checks whose answer never changes over the inputs (a condition that cannot fail, "
                         "or cannot hold):")
            lines += [f"  - {c}" for c in self.constant]
        if self.failing_at_start and self.reject_failing_at_start:
            lines.append("'during' checks that already fail on the starting state (the subgoal would stop at once):")
            lines += [f"  - {f}" for f in self.failing_at_start]
        head = "path coverage failed:" if lines else "path coverage passed"
        if self.failing_at_start and not self.reject_failing_at_start:
            lines.append("'during' checks already violated on the starting state (a violation of the world, "
                         "reported as an alarm; not a reason to reject the program):")
            lines += [f"  - {f}" for f in self.failing_at_start]
        if self.unreached:
            lines.append(f"branches no input reached ({len(self.covered)}/{len(self.branches)} covered over "
                         f"{self.n_inputs} inputs; reported, not a reason to reject by itself):")
            lines += [f"  - {b.describe()}" for b in self.unreached[:MAX_LISTED]]
        return head + ("\n" + "\n".join(lines) if lines else "")


class CoverageError(ProgramError):
    """Path coverage found problems; ``report`` holds the details, ``str()`` the coder feedback."""

    def __init__(self, report: CoverageReport) -> None:
        super().__init__(report.message())
        self.report = report


SandboxSource = Sandbox | Callable[[], Sandbox]


def part_groups(constraints: list[Constraint]) -> dict[int, list[int]]:
    """Element id -> the ids of the elements of its object part (by the constraints' ``parts`` and
    ``element_ids``), for the probes that move a part as one."""
    owner: dict[int, tuple[str, str]] = {}
    for c in constraints:
        if len(c.parts) == len(c.element_ids):
            for spec, i in zip(c.parts, c.element_ids):
                owner.setdefault(int(i), (spec.obj, spec.part))
    out: dict[int, list[int]] = {}
    for i, o in owner.items():
        out[i] = sorted(j for j, oj in owner.items() if oj == o)
    return out


def check_path_coverage(
    source: str,
    constraints: list[Constraint],
    elements: dict[int, np.ndarray],
    history: dict[int, np.ndarray] | None,
    history_t: np.ndarray | None,
    t: float,
    sandbox_or_factory: SandboxSource,
    n_perturbations: int = 96,
    seed: int = 0,
    deadline_s: float | None = None,
    require_full_coverage: bool = False,
    reject_failing_at_start: bool = False,
) -> CoverageReport:
    """Drive every branch of every check with the current state and perturbations of it.

    Args:
        source: the monitor program (validated here again).
        constraints: the subgoal's constraints (order = verdict order).
        elements: element id -> (k, 3) current points, world metres.
        history: element id -> (T, k, 3) oldest first, or None (T = 1).
        history_t: (T,) seconds, or None.
        t: current time, seconds.
        sandbox_or_factory: a started :class:`Sandbox` (its loaded program is replaced by the
            instrumented one; load the real program afterwards) or a callable returning a new one,
            which is started and closed here.
        n_perturbations: perturbed inputs besides the current state.
        seed: seed of the perturbations (deterministic).
        deadline_s: per-input deadline; default: 5x the sandbox deadline, at least
            :data:`MIN_PROBE_DEADLINE_S` (coverage runs once per subgoal, not in the control loop, and
            instrumentation costs a little).
        require_full_coverage: True also rejects a program for unreached branches alone.
        reject_failing_at_start: True also rejects a program whose ``during`` checks fail on the starting
            state (by default they are accepted and listed in ``violated_at_start``).
    Returns:
        The report, when nothing is wrong (``violated_at_start``: the ``during`` verdicts that are False on
        the starting state, for the caller to report as violations).
    Raises:
        CoverageError: exceptions, malformed results, overruns, checks with a constant answer (and
            ``during`` checks failing at the start with ``reject_failing_at_start``, unreached branches with
            ``require_full_coverage``); the message lists them with the inputs that caused them.
        ProgramError: the program does not pass static validation or does not load.
    """
    tree = validate_program(source, constraints)
    _, branches = instrument(tree)
    own = not isinstance(sandbox_or_factory, Sandbox)
    sandbox = sandbox_or_factory() if own else sandbox_or_factory
    try:
        if own:
            sandbox.start()
        sandbox.load(source, constraints, coverage=True)
        if sandbox.n_branches != len(branches):
            raise ProgramError(f"branch tables differ between control process ({len(branches)}) and worker "
                               f"({sandbox.n_branches})")
        deadline = deadline_s if deadline_s is not None else max(5 * sandbox.deadline_s, MIN_PROBE_DEADLINE_S)
        report = CoverageReport(branches=branches, reject_failing_at_start=reject_failing_at_start)
        seen: set[tuple[str, str]] = set()
        overruns = 0
        outcomes = {c.id: (0, 0) for c in constraints}
        probes = make_probes(elements, history, history_t, t, n_perturbations, seed, groups=part_groups(constraints),
                             related=[[int(i) for i in c.element_ids] for c in constraints])
        for k, probe in enumerate(probes):
            restarts = sandbox.n_restarts
            verdicts = sandbox.evaluate(probe.elements, probe.history, probe.history_t, t, deadline_s=deadline)
            report.n_inputs += 1
            if sandbox.n_restarts != restarts:  # overrun or crash: the worker was replaced
                overruns += 1
                ids = ", ".join(c.function_name for c in constraints)
                report.faults.append(f"one of {ids}: {verdicts[0].reason.removeprefix('fault: ')} "
                                     f"(input {k}: {probe.description})")
                sandbox.start()  # wait for the replacement (it reloads the instrumented program)
                if overruns >= MAX_OVERRUNS:
                    break  # each overrun costs a worker restart; the fault is already reported
                continue
            report.covered.update(sandbox.last_marks)
            for v in verdicts:
                if not v.fault:
                    n_true, n_false = outcomes[v.constraint_id]
                    outcomes[v.constraint_id] = (n_true + v.ok, n_false + (not v.ok))
                if v.fault and (v.constraint_id, v.reason) not in seen:
                    seen.add((v.constraint_id, v.reason))
                    report.faults.append(f"check_{v.constraint_id}: {v.reason.removeprefix('fault: ')} "
                                         f"(input {k}: {probe.description})")
                elif k == 0 and not v.fault and not v.ok and v.phase is Phase.DURING:
                    report.failing_at_start.append(f"check_{v.constraint_id}: returned False, {v.reason!r}")
                    report.violated_at_start.append(v)
        if overruns >= MAX_OVERRUNS:
            report.faults.append(f"stopped after {overruns} overruns/crashes ({report.n_inputs} of {len(probes)} "
                                 "inputs tried); branch coverage not assessed")
            report.covered.clear()
        else:
            report.outcomes = {f"check_{cid}": n for cid, n in outcomes.items()}
            for cid, (n_true, n_false) in outcomes.items():
                if n_true and not n_false:
                    report.constant.append(f"check_{cid}: returned True on all {n_true} inputs it answered, so "
                                           "it can never report a violation")
                elif n_false and not n_true:
                    report.constant.append(f"check_{cid}: returned False on all {n_false} inputs it answered, "
                                           "so it can never be satisfied")
        entered = {b.function for b in branches if b.kind == "entry" and b.id in report.covered}
        report.unreached = [b for b in branches if b.id not in report.covered and b.function in entered]
    finally:
        if own:
            sandbox.close()
    if not report.ok or (report.unreached and require_full_coverage):
        raise CoverageError(report)
    return report
