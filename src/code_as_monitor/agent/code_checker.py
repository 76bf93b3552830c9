"""Code-as-Monitor's per-subgoal checker: paint elements, write and validate the monitor program,
then track the elements and run the program in the sandbox on every due frame.

At the subgoal's start (:meth:`CodeChecker.begin`): paint -> write the program (VLM call 2, plus
bounded regenerations on validation / path-coverage errors) -> reset the tracker. A ``during`` check of
the accepted program that is already False on the starting state (path coverage's ``violated_at_start``:
the program works, the world violates its constraint) is an alarm at once, with the check's reason, and
ends the subgoal ``violated`` before its action starts. Every due frame
(:meth:`CodeChecker.frame`): track, push the history, evaluate every check. A violated ``during``
check ends the subgoal (``violated``, halt); every ``upon`` check holding for ``upon_dwell_frames``
frames ends it (``success``, halting a still-moving policy); a policy that finished is judged on
re-measured elements over up to ``settle_frames`` more frames (``success`` or ``reactive_failure``).
A check that reads a stale element (lost by the tracker) gets no verdict that frame, unless every stale element it
reads is a monotone member of its constraint (``Constraint.monotone``) and it holds on the elements seen.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from code_as_monitor.agent.check_modes import kept_constraints
from code_as_monitor.agent.completion import SubgoalCompletion
from code_as_monitor.agent.config import AgentConfig
from code_as_monitor.agent.rest import HOLD_WINDOW_S, in_hand
from code_as_monitor.agent.subgoal import MonitorContext, SubgoalEnd, runs_to_end
from code_as_monitor.core.constraints import Phase, Subgoal, Verdict
from code_as_monitor.core.elements import Element
from code_as_monitor.core.errors import PerceptionError, ProgramError, VLMError
from code_as_monitor.core.observation import Observation

FrameFn = Callable[[Observation, list[Element], dict[int, np.ndarray], list[Verdict], str], None]
PromptFn = Callable[[int, Subgoal, dict[str, np.ndarray], str], None]


class CodeChecker(SubgoalCompletion):
    """Watches one subgoal at a time with a generated monitor program.

    Args:
        coder: ``write_program(subgoal, elements, images, check, max_retries) -> str``.
        painter: :class:`~code_as_monitor.painter.Painter` (``paint``, ``build_element``).
        tracker: ``reset(obs, elements)``, ``step(obs) -> TrackResult``, ``set_reacquire(fn)``.
        runtime: a monitor runtime (``start``/``step``; closed by its owner).
        history_factory: builds an element history with ``push(t, points)`` / ``arrays()``.
        config: the loop settings (rate, dwell, settle, refresh).
        on_frame: called every judged frame with the elements at their tracked positions (videos,
            live views); ``on_prompt``: with each subgoal's visual prompts and program.
    """

    def __init__(self, coder: Any, painter: Any, tracker: Any, runtime: Any, history_factory: Callable[[int], Any],
                 config: AgentConfig | None = None, on_frame: FrameFn | None = None,
                 on_prompt: PromptFn | None = None) -> None:
        self.coder = coder
        self.painter = painter
        self.tracker = tracker
        self.runtime = runtime
        self.history_factory = history_factory
        self.cfg = config or AgentConfig()
        self.on_frame = on_frame
        self.on_prompt = on_prompt
        self._settling = False
        self._unwatched = False
        self._upon: list[Any] = []
        self._known: dict = {}  # (object, part, kind) -> KnownElement: where the tracker last had each part
        # The last judged frame: (t, element id -> (k, 3) points, stale ids, element id -> the least support its tracker
        # reported since its last measurement (inf: a measurement), element id -> the measurement that replaced it).
        self._last: tuple | None = None
        self._tracked: dict[int, float] = {}  # element id -> least tracker support since its last measurement
        self._elements: list[Element] = []
        self._painted: Any = None
        # (t, tip (3,), stale ids) of each judged frame: the element positions of that frame are in the history
        self._tips: deque[tuple[float, np.ndarray, set[int]]] = deque(maxlen=64)

    def start_episode(self, obs: Observation) -> None:
        self._known.clear()
        self._last = None
        self._elements = []
        self._survey(obs)
        return None

    def _survey(self, obs: Observation) -> None:
        """Remember every scene object as a whole-object point from the episode's first frame, so that an object
        no subgoal has watched yet can still be carried over when the robot later hides it (the arm holding one
        block over another at the start of the place). Only when the painter builds elements by object and the
        observation names its objects; an object no view sees now is simply not remembered."""
        build = getattr(self.painter, "build_elements", None)
        if build is None or not obs.objects or not getattr(self.painter, "connect_points", True):
            return
        from code_as_monitor.core.elements import ElementKind, ElementSpec
        from code_as_monitor.painter.carry_over import key_of, known_from

        specs = {i: ElementSpec(o.replace("_", " "), o, "", ElementKind.POINT)
                 for i, o in enumerate(o for o in obs.objects if o != "robot")}
        try:
            built = build(obs, specs)
        except PerceptionError:
            return  # the survey is an aid: a subgoal's own painting reports what it cannot see
        for i, el in built.items():
            if el is not None:
                self._known[key_of(specs[i])] = known_from(el, el.points, obs.t)

    def _remember(self) -> None:
        """Fold where the tracker last had the watched subgoal's elements into the remembered estimates (by object,
        part and kind) that the painter may carry over when the robot hides a part (:mod:`~code_as_monitor.painter.
        carry_over`); elements stale at that frame, and the robot's own, are not remembered. Each remembers the
        least support its tracker reported since it was last measured (a tracked estimate is no better than its
        tracker's weakest frame). Not with a painter that splits elements into points (CP off): its points share
        one key."""
        last, self._last = self._last, None
        if last is None or not getattr(self.painter, "connect_points", True):
            return
        from code_as_monitor.painter.carry_over import key_of, known_from, object_rotations

        t, points, stale, tracked, measured = last
        specs = getattr(self._painted, "specs", {})
        kept = [e for e in self._elements if specs.get(e.id) is not None and points.get(e.id) is not None
                and e.owner[0] != "robot" and e.id not in stale]
        moves: dict[str, list] = {}
        for e in kept:  # an object's elements together tell how it turned (its clouds turn with it)
            moves.setdefault(e.owner[0], []).append((measured.get(e.id, e).points, points[e.id]))
        turns = object_rotations(moves)
        for e in kept:
            self._known[key_of(specs[e.id])] = known_from(measured.get(e.id, e), points[e.id], t,
                                                          tracked.get(e.id, 0.0), turns.get(e.owner[0]))

    def holding(self, obs: Observation) -> bool:
        """Whether the robot holds one of the watched objects now (:func:`~code_as_monitor.agent.rest.in_hand`), from
        where the tracker last had the elements (fresh ones only): asked when a subgoal ended in failure."""
        if self._last is None:
            return False
        _, points, stale, _, _ = self._last
        owners = {e.id: e.owner[0] for e in self._elements}
        return in_hand(obs.robot, {i: p for i, p in points.items() if i not in stale}, owners, self._before(obs.t))

    def _before(self, t: float) -> tuple[np.ndarray, dict[int, np.ndarray]] | None:
        """(tip, element id -> centroid of its fresh points) at the first judged frame of the last
        ``HOLD_WINDOW_S`` seconds before ``t``, the positions read from the element history; None if none."""
        frame = next(((ft, tip, st) for ft, tip, st in self._tips if ft >= t - HOLD_WINDOW_S - 1e-9), None)
        if frame is None:
            return None
        ft, tip, stale = frame
        H, ht = self._history.arrays(copy=False)
        j = int(np.searchsorted(ht, ft))  # the judged frame's push (a re-measurement may follow at the same t)
        if j >= len(ht) or ht[j] != ft:
            return None
        return tip, {i: H[i][j].mean(axis=0) for i in H if i not in stale}

    def close(self) -> None:
        return None

    # --- subgoal start --------------------------------------------------------------------------------
    def begin(self, index: int, subgoal: Subgoal, obs: Observation, ctx: MonitorContext) -> SubgoalEnd | None:
        kept = kept_constraints(subgoal.constraints, self.cfg.checks)
        if len(kept) != len(subgoal.constraints):
            ctx.emit("checks_dropped", t=obs.t, checks=self.cfg.checks,
                     dropped=[c.id for c in subgoal.constraints if all(c is not k for k in kept)])
            # A copy: the planner's subgoal (the next plan's "previous") keeps every constraint.
            subgoal = replace(subgoal, constraints=[replace(c, parts=list(c.parts)) for c in kept])
        self._unwatched = not subgoal.constraints
        if self._unwatched:  # no check of the kind kept: the policy's own "done" ends the subgoal
            self._subgoal, self._attempts, self._settling = subgoal, 0, False
            self._period = 1.0 / self.cfg.frame_hz
            self._next_frame = obs.t + self._period
            return None
        self._remember()
        painted = self.painter.paint(obs, subgoal, known=self._known) if self._known \
            else self.painter.paint(obs, subgoal)
        for d in getattr(painted, "carried", ()):
            ctx.emit("element_carry", t=obs.t, **d.to_dict())
        for m in painted.missing:
            ctx.emit("element_missing", t=obs.t, spec=m.to_dict())
        ctx.emit("elements", t=obs.t, legend=painted.legend(), seconds=painted.seconds)
        if painted.missing:
            names = ", ".join(f"{s.obj}/{s.part}" if s.part else s.obj for s in painted.missing)
            return SubgoalEnd("error", f"cannot see {names}")
        elements = painted.elements
        positions = {e.id: e.points for e in elements}
        # A paint is a measurement; a carried element starts from its tracker's weakest frame.
        self._tracked = {e.id: (e.support.tracked if e.support is not None else math.inf) for e in elements}
        self._last = (obs.t, positions, set(), dict(self._tracked), {})
        self._tips.clear()
        history = self.history_factory(self.cfg.history_len)
        history.push(obs.t, positions)

        attempts = {"n": 0}
        accepted: dict[str, Any] = {"report": None}  # the coverage report of the program last accepted

        def check(source: str) -> None:
            attempts["n"] += 1
            accepted["report"] = None
            H, ht = history.arrays()
            accepted["report"] = self.runtime.start(source, subgoal.constraints, positions, H, ht, obs.t)

        try:
            source = self.coder.write_program(subgoal, elements, painted.images, check=check,
                                              max_retries=self.cfg.code_retries)
        except (ProgramError, VLMError) as exc:
            ctx.emit("program_rejected", t=obs.t, error=str(exc))
            return SubgoalEnd("error", f"no valid monitor program: {exc}", code_attempts=attempts["n"])
        ctx.episode.programs.append(source)
        ctx.emit("program", t=obs.t, index=index, source=source, attempts=attempts["n"])
        if self.on_prompt is not None:
            self.on_prompt(index, subgoal, painted.images, source)

        self.tracker.reset(obs, elements)
        self.tracker.set_reacquire(lambda o, el: self.painter.build_element(o, el.id, painted.specs[el.id]))
        self._subgoal, self._painted, self._elements, self._history = subgoal, painted, elements, history
        self._attempts = attempts["n"]
        self._period = 1.0 / self.cfg.frame_hz
        self._next_frame = obs.t + self._period
        self._upon = subgoal.upon()
        self._upon_streak = 0
        self._verdict_state: dict[str, str] = {}  # constraint id -> "ok" | "violated" | "fault"
        self._uses = {c.id: set(c.element_ids) for c in subgoal.constraints}
        self._monotone = {c.id: c.monotone_element_ids() for c in subgoal.constraints}
        self._unknown_before: set[str] = set()
        self._settling = False
        at_start = list(getattr(accepted["report"], "violated_at_start", None) or ())
        if at_start:
            return self._violated_at_start(obs, at_start, ctx)
        return None

    def _violated_at_start(self, obs: Observation, verdicts: list[Verdict], ctx: MonitorContext) -> SubgoalEnd:
        """The world already violates ``during`` constraints on the subgoal's starting state: alarm on the first
        (in constraint order, as a frame would), end the subgoal before its action starts (nothing to halt)."""
        for v in verdicts:
            self._verdict_state[v.constraint_id] = "violated"
            ctx.emit("verdict", **v.to_dict())
        v = verdicts[0]
        ctx.alarm(self._subgoal, v.constraint_id, v.phase.value, v.reason, obs.t)
        if self.on_frame is not None:
            self.on_frame(obs, self._elements, {}, verdicts, f"VIOLATION {v.constraint_id}: {v.reason}")
        return self._end_of("violated", f"{v.constraint_id}: {v.reason}")

    # --- every frame ------------------------------------------------------------------------------------
    def frame_due(self, t: float, policy_done: bool) -> bool:
        if self._settling:
            return t + 1e-9 >= self._settle_next
        return policy_done or t + 1e-9 >= self._next_frame

    def frame(self, obs: Observation, policy_done: bool, ctx: MonitorContext) -> SubgoalEnd | None:
        if self._settling:
            return self._settle(obs, ctx)
        self._next_frame += self._period
        end = self._end_of
        if self._unwatched:
            if policy_done:
                return end("success", f"policy finished (no {self.cfg.checks} check to run)")
            return end("timeout", "time limit reached during the subgoal") if ctx.out_of_time(obs.t) else None
        try:
            verdicts, tr = self._monitor_frame(obs, ctx)
        except PerceptionError as exc:
            return end("error", f"perception failed: {exc}", halt=True)
        # A check that reads a stale element (lost by the tracker, not yet re-acquired, or with
        # non-finite points) has no verdict this frame: it can neither raise an alarm nor complete
        # the subgoal.
        stale_ids = {i for i, st in tr.stale.items() if np.any(st)}
        stale_ids |= set(getattr(self.runtime, "stale_elements", ()))  # NaN/inf points: as if lost
        unknown = {cid for cid, ids in self._uses.items() if ids & stale_ids}
        # ... unless the stale ones are monotone members of its constraint and it holds on those seen
        seen = self._judged_on_seen(tr.points, stale_ids, unknown, obs)
        unknown -= set(seen)
        if unknown != self._unknown_before:
            ctx.emit("verdicts_unknown", t=obs.t, constraints=sorted(unknown), stale_elements=sorted(stale_ids),
                     judged_on_seen=sorted(seen))
            self._unknown_before = unknown
        verdicts = [seen.get(v.constraint_id, v) for v in verdicts if v.constraint_id not in unknown]
        violated = [v for v in verdicts if v.phase is Phase.DURING and not v.ok and not v.fault]
        upon_v = [v for v in verdicts if v.phase is Phase.UPON and not v.fault]
        for v in verdicts:
            if v.fault:
                ctx.emit("program_fault", t=v.t, constraint_id=v.constraint_id, reason=v.reason)
        upon = self._upon
        upon_ok = bool(upon) and len(upon_v) == len(upon) and all(v.ok for v in upon_v)
        self._upon_streak = self._upon_streak + 1 if upon_ok else 0
        if violated:
            v = violated[0]
            ctx.alarm(self._subgoal, v.constraint_id, v.phase.value, v.reason, v.t)
            self._frame(obs, tr, verdicts, f"VIOLATION {v.constraint_id}: {v.reason}")
            return end("violated", f"{v.constraint_id}: {v.reason}", halt=True)
        early = self.cfg.halt_on_upon and self._upon_streak >= self.cfg.upon_dwell_frames and not runs_to_end(
            self._subgoal, self.cfg.run_to_end)
        if upon_ok and (policy_done or early):
            confirmed = self._confirm(obs, tr, upon_v, ctx) if self.cfg.refresh_on_done else upon_v
            if confirmed is not None:
                if not policy_done:
                    ctx.emit("early_halt", t=obs.t, reason="all upon constraints satisfied")
                self._frame(obs, tr, verdicts, "subgoal complete")
                return end("success", "; ".join(v.reason for v in confirmed), halt=not policy_done)
            self._upon_streak = 0  # not on re-measured elements: go on (at the policy's end, the settle judges)
        self._frame(obs, tr, verdicts, "")
        if policy_done:
            # Judge the upon checks on re-measured elements, starting with this very frame.
            self._settling = True
            self._settle_attempt = 0
            return self._settle(obs, ctx)
        if ctx.out_of_time(obs.t):
            # Not a monitor decision: the episode ends here, the policy is not halted (a task that
            # scores "halted in time" must not count the clock running out as a halt).
            return end("timeout", "time limit reached during the subgoal")
        return None

    def _end_of(self, outcome: str, reason: str, halt: bool = False) -> SubgoalEnd:
        return SubgoalEnd(outcome, reason, halt=halt, code_attempts=self._attempts)

    def _monitor_frame(self, obs: Observation, ctx: MonitorContext) -> tuple[list[Verdict], Any]:
        """Track, push the history, evaluate every check in the sandbox. Verdict events are written
        when a check's state (ok / violated / fault) changes, not every frame."""
        tr, stale_ids = self._track(obs)
        self._history.push(obs.t, tr.points)
        self._last = (obs.t, dict(tr.points), stale_ids, dict(self._tracked), {})
        if obs.robot is not None:  # where the tip was and which elements were fresh, for holding()
            self._tips.append((obs.t, obs.robot.tip, stale_ids))
        H, ht = self._history.arrays()
        verdicts = self.runtime.step(tr.points, H, ht, obs.t)
        for v in verdicts:
            state = "fault" if v.fault else ("ok" if v.ok else "violated")
            if self._verdict_state.get(v.constraint_id) != state:
                self._verdict_state[v.constraint_id] = state
                ctx.emit("verdict", **v.to_dict())
        return verdicts, tr

    def _track(self, obs: Observation) -> tuple[Any, set[int]]:
        """One tracker step: its result and stale element ids, the supports folded in (every tracked frame)."""
        tr = self.tracker.step(obs)
        stale_ids = {i for i, st in tr.stale.items() if np.any(st)}
        self._fold_support(tr, stale_ids)
        return tr, stale_ids

    def _fold_support(self, tr: Any, stale_ids: set[int]) -> None:
        """Lower each element's least tracker support since its last measurement by this frame's report
        (``TrackResult.support``; an element the tracker does not report rests on no known support). A stale
        element keeps its last position, not a new estimate: its figure is unchanged."""
        reported = getattr(tr, "support", {}) or {}
        for eid in tr.points:
            if eid not in stale_ids:
                self._tracked[eid] = min(self._tracked.get(eid, math.inf), float(reported.get(eid, 0.0)))

    def _frame(self, obs: Observation, tr: Any, verdicts: list[Verdict], banner: str) -> None:
        """Hand the frame to ``on_frame`` with the elements at their tracked positions."""
        if self.on_frame is None:
            return
        current = [Element(e.id, e.name, e.kind, tr.points.get(e.id, e.points), e.owner, e.color)
                   for e in self._elements]
        self.on_frame(obs, current, tr.stale, verdicts, banner)

__all__ = ["CodeChecker"]
