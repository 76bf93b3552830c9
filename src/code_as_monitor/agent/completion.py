"""How a Code-as-Monitor subgoal ends on its ``upon`` checks: re-measured elements, not tracker drift.

A mixin of :class:`~code_as_monitor.agent.code_checker.CodeChecker` (it uses the checker's painter, runtime,
tracker, history, elements and settings). Upon checks that hold on the tracked positions complete a subgoal only
if they hold on re-measured elements too (:meth:`SubgoalCompletion._confirm`); a policy that finished with an upon
check not holding is judged on re-measured elements over up to ``settle_frames`` more frames
(:meth:`SubgoalCompletion._settle`). Re-measured (:meth:`SubgoalCompletion._refreshed`): an element the tracker
saw move this subgoal is painted again from the current frame; one at rest keeps its measurement from the
subgoal's start, where a tracker that registered it has carried it (:func:`carried_at_rest`), unless that one was
weak: then it is painted again, or, when a tracker that registers it now carried it away from that measurement,
judged where the tracker has it (:meth:`SubgoalCompletion._carried_away`). When the planner calls the task complete,
the last subgoal's upon checks are judged once more on the scene at rest (:meth:`SubgoalCompletion.follow`,
:meth:`SubgoalCompletion.at_rest`): a book that passed "standing" while it was still tipping over has fallen by then.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from code_as_monitor.agent.subgoal import MonitorContext, SubgoalEnd
from code_as_monitor.core.constraints import Verdict
from code_as_monitor.core.elements import Element, ElementKind, stood_in
from code_as_monitor.core.observation import Observation, engaged

TRACKED_AT_REST = 0.5
"""An element at rest keeps the position its tracker carried its start measurement to when the tracker's weakest frame
since rested on at least this fraction of the observations the measurement did (:func:`carried_at_rest`)."""

CARRIED_NOT_REPAINTED = 0.005
"""Metres: a point element at rest (moved less than ``refresh_motion``) whose weak start measurement a registering
tracker has carried further than this is judged where the tracker has it, not painted again
(:meth:`SubgoalCompletion._carried_away`). Above the 1-2 mm a resting object's registration moves it (a block nudged
by the one set down on it: 1.9 mm); a part that moved that far in its place (a bulb screwed 1.5 cm into its socket)
can now be partly inside a sibling, and a fresh paint measures what is left visible of it."""


def carried_at_rest(e: Element, tracked_points: np.ndarray, stale: np.ndarray | None,
                    tracked_support: float | None) -> bool:
    """Whether an element ``e`` the tracker saw at rest (moved no more than ``refresh_motion``) is judged where the
    tracker has it, ``tracked_points`` (k, 3) world metres, rather than at its measurement from the subgoal start.

    At rest is not unmoved: a block nudged a few millimetres by the one set down on it is where the tracker carried
    its measurement, not where it was painted (stack p = 0.3, 1607472740 with ``depth``: the start measurement of the
    green block was 1.9 mm off after such a nudge, the tracked one 0.4 mm). The tracked position is used when it is
    fresh this frame and rests on a registration: the tracker's weakest frame since the measurement
    (``tracked_support``, the fewest observations it reported; ``inf`` for exact motion) had at least
    :data:`TRACKED_AT_REST` of the measurement's points the robot did not hide. A point tracker's few anchors are not
    that (its drift is what the start measurement guards against), and neither is a tracker that reports nothing."""
    if tracked_support is None or (stale is not None and np.any(stale)) or tracked_points.shape != e.points.shape \
            or not np.all(np.isfinite(tracked_points)):
        return False
    sup = e.support
    if sup is None:
        return math.isinf(tracked_support)
    return tracked_support >= TRACKED_AT_REST * float(sup.points) * (1.0 - float(sup.robot_hidden))


class SubgoalCompletion:
    """The end-of-subgoal judgement of :class:`~code_as_monitor.agent.code_checker.CodeChecker` (a mixin)."""

    cfg: Any
    painter: Any
    runtime: Any
    tracker: Any
    _elements: list[Element]
    _painted: Any
    _history: Any
    _tracked: dict[int, float]
    _upon: list[Any]
    _uses: dict[str, set[int]]
    _monotone: dict[str, set[int]]
    _period: float
    _subgoal: Any
    _last: tuple | None
    _settling: bool
    _settle_attempt: int
    _settle_next: float
    _unwatched: bool
    _track: Callable[[Observation], tuple[Any, set[int]]]
    _end_of: Callable[..., SubgoalEnd]

    # --- the policy has finished: judge the upon checks ---------------------------------------------------
    def _remeasured_at_rest(self, obs: Observation, e: Element, ctx: MonitorContext) -> Element | None:
        """A fresh measurement of ``e``, an element the tracker saw at rest all subgoal, to judge the upon checks on
        instead of its measurement from the subgoal start; None keeps that one.

        The start measurement is kept unless its own support calls it weak (:meth:`ElementSupport.weak
        <code_as_monitor.core.elements.ElementSupport.weak>`: e.g. painted mostly through the robot, whose arm is
        often over the next target when a subgoal starts) and a measurement from this static frame is not weak.
        A strong start measurement is kept even when the fresh one differs: re-painting now measures what is left
        visible (the sides of a block another block now covers)."""
        sup = e.support
        if sup is None or not sup.weak():
            return None
        fresh = self.painter.build_element(obs, e.id, self._painted.specs[e.id])
        if fresh is None or fresh.support is None or fresh.support.weak() or fresh.points.shape != e.points.shape:
            return None
        shift = float(np.linalg.norm(fresh.points.mean(axis=0) - e.points.mean(axis=0)))
        ctx.emit("element_remeasured", t=obs.t, id=e.id, name=e.name, robot_hidden_start=round(sup.robot_hidden, 3),
                 robot_hidden_now=round(fresh.support.robot_hidden, 3), shift=round(shift, 4))
        return fresh

    def _carried_away(self, obs: Observation, e: Element, tracked_points: np.ndarray, stale: np.ndarray | None,
                      support_now: float | None, ctx: MonitorContext) -> bool:
        """Whether ``e``, at rest by ``refresh_motion``, with a weak start measurement, is judged where its tracker has
        it now (``tracked_points`` (k, 3) world metres) instead of painted again: the tracker carried it more than
        :data:`CARRIED_NOT_REPAINTED` from that measurement and registers it this frame on as many observations as
        :func:`carried_at_rest` asks of its weakest frame (``support_now``, this frame's; the weakest may have been
        while the gripper held it). A bulb screwed 1.5 cm down has its neck inside the socket at the end, and painted
        afresh from the front view alone its centre read 42 mm above the socket's where the tracked one read under 39
        (screw-bulb seed 21; the bulb's fresh paints are biased up once seated, in every view set).

        Points only: a registration fixes a shape's position better than its turn (a symmetric one's turn not at all),
        and a line or surface is read for its direction. A book's spine turned upright about its middle moved 6.5 mm
        and the ``depth`` tracker still had it lying, 90 degrees from vertical, where a fresh paint saw it upright
        (stow-book (c) 1048184493: one false "not upright" and a re-plan, with this rule on lines too)."""
        if e.kind is not ElementKind.POINT or e.support is None or not e.support.weak() \
                or not carried_at_rest(e, tracked_points, stale, support_now):
            return False
        moved = float(np.linalg.norm(tracked_points.mean(axis=0) - e.points.mean(axis=0)))
        if moved <= CARRIED_NOT_REPAINTED:
            return False
        ctx.emit("element_kept_tracked", t=obs.t, id=e.id, name=e.name, moved=round(moved, 4))
        return True

    def _refreshed(self, obs: Observation, tr: Any, ctx: MonitorContext,
                   confirming: bool = False) -> tuple[dict, dict, dict, dict]:
        """The elements to judge the upon checks on: (points, stale, tracked support, measured elements) by id.

        With ``refresh_on_done``, an element the tracker saw move more than ``refresh_motion`` this subgoal is painted
        again from this frame; one at rest all along keeps its measurement from the subgoal start, unless that one
        was weak (:meth:`_remeasured_at_rest`; :meth:`_carried_away`: the tracker's position when it carried it away
        from that measurement). Without it, the tracked positions. ``confirming``
        (:meth:`_confirm`): only moved whole objects, whose box the painter completes behind what hides them, are
        painted again; a moved part keeps its tracked position, since what a view shows of a part at a subgoal's end
        can be a misleading piece of it (a book held upright with its spine behind the cover, seen end-on, re-paints
        87-90 degrees off vertical, and not weak: stow-book (c) episodes 476548990 and 2125215470)."""
        points = dict(tr.points)
        stale = {i: np.asarray(st) for i, st in tr.stale.items()}
        tracked, measured = dict(self._tracked), {}
        support_now = getattr(tr, "support", {}) or {}  # this frame's (the tracked figures are the weakest since)
        if not self.cfg.refresh_on_done:
            return points, stale, tracked, measured
        H0, _ = self._history.arrays()
        for e in self._elements:
            if e.owner[0] == "robot" or e.id not in H0:
                continue
            # moved over the history, or away from its measurement: the history holds the last ``history_len``
            # frames only, so on a long subgoal its oldest frame is not the subgoal's start (a rope bead dragged
            # early and still since is not "at rest all along", and its start measurement is not where it is)
            moved = max(np.linalg.norm(H0[e.id][-1].mean(axis=0) - H0[e.id][0].mean(axis=0)),
                        np.linalg.norm(np.asarray(points[e.id]).mean(axis=0) - e.points.mean(axis=0)))
            if moved <= self.cfg.refresh_motion:
                # at rest all along: its measurement from the subgoal start, unless that one was weak (kept, it is
                # as good as the tracker that says it rested: its tracked support stays; re-measured, it is new);
                # kept, it is where a tracker that registered it has carried it (a block nudged 2 mm by the one
                # landing on it is not where it was painted: :func:`carried_at_rest`)
                if self._carried_away(obs, e, np.asarray(points[e.id]), stale.get(e.id), support_now.get(e.id), ctx):
                    stale[e.id] = np.zeros(len(points[e.id]), dtype=bool)
                    continue  # judged where the tracker has it now (its tracked support stays)
                kept = self._remeasured_at_rest(obs, e, ctx) or e
                if kept is e and not carried_at_rest(e, np.asarray(points[e.id]), stale.get(e.id), tracked.get(e.id)):
                    points[e.id] = e.points
                elif kept is not e:
                    points[e.id] = kept.points
                stale[e.id] = np.zeros(len(points[e.id]), dtype=bool)
                if kept is not e:
                    tracked[e.id], measured[e.id] = math.inf, kept
                continue
            if confirming and e.owner[1]:
                continue  # a part keeps its tracked position (see the docstring)
            fresh = self.painter.build_element(obs, e.id, self._painted.specs[e.id])
            # a part no view sees now, painted from its whole object, is not where the part is: the tracker's
            if fresh is not None and fresh.points.shape == points[e.id].shape and not stood_in(e, fresh):
                points[e.id] = fresh.points
                stale[e.id] = np.zeros(len(fresh.points), dtype=bool)
                tracked[e.id], measured[e.id] = math.inf, fresh  # measured again now
        return points, stale, tracked, measured

    def _confirm(self, obs: Observation, tr: Any, upon_v: list[Verdict], ctx: MonitorContext) -> list[Verdict] | None:
        """The upon verdicts on re-measured elements (:meth:`_refreshed`) when every one of them holds, else None.

        Upon checks that hold on tracked positions complete a subgoal only if they hold on a fresh measurement too:
        a tracker's error at the end of a subgoal (a block registered 5 mm sideways as it settled under the cup)
        must not pass an offset the task's tolerance fails, as it cannot fail one it passes (the settle path)."""
        points, stale, tracked, measured = self._refreshed(obs, tr, ctx, confirming=True)
        if not measured:
            return upon_v
        stale_ids = {i for i, st in stale.items() if np.any(st)}
        again = self._upon_verdicts(points, stale_ids, obs)
        ok = len(again) == len(self._upon) and all(v.ok for v in again)
        ctx.emit("completion_check", t=obs.t, confirmed=ok, remeasured=sorted(measured),
                 verdicts=[v.to_dict() for v in again])
        if not ok:
            return None
        self._last = (obs.t, dict(points), stale_ids, tracked, measured)
        return again

    def _upon_verdicts(self, points: dict, stale_ids: set[int], obs: Observation) -> list[Verdict]:
        """The program's upon verdicts at ``obs`` on ``points`` (element id -> (k, 3) world metres) with the current
        history; a fault, or a check reading an element in ``stale_ids``, is no verdict, unless those are monotone
        members of its constraint and it holds on the elements seen (:meth:`_judged_on_seen`)."""
        H, ht = self._history.arrays()
        ids = {c.id for c in self._upon}
        verdicts = [v for v in self.runtime.step(points, H, ht, obs.t) if v.constraint_id in ids and not v.fault]
        unknown = {v.constraint_id for v in verdicts if self._uses[v.constraint_id] & stale_ids}
        seen = self._judged_on_seen(points, stale_ids, unknown, obs)
        return [seen.get(v.constraint_id, v) for v in verdicts
                if v.constraint_id not in unknown or v.constraint_id in seen]

    def _judged_on_seen(self, points: dict, stale_ids: set[int], unknown: set[str],
                        obs: Observation) -> dict[str, Verdict]:
        """Verdicts for checks that have none this frame because they read stale elements, when every stale element
        they read is a monotone member of their constraint (:attr:`~code_as_monitor.core.constraints.Constraint.
        monotone`: a set more members can only help to hold, like a rope's beads covering a gap): the program runs
        once more with the stale elements left out of ``E`` and ``H``, and a check that holds on the elements seen
        gets that verdict (the unseen members cannot undo it); one that does not hold stays without a verdict.

        Not while the end effector is engaged at ``obs`` (:func:`~code_as_monitor.core.observation.engaged`:
        gripper closed or suction on, :attr:`RobotState.gripper
        <code_as_monitor.core.observation.RobotState.gripper>`): the members hidden then are the ones under the
        hand, which may be in its grip, and a held member drags the others when it moves or when a halt lets it go.
        Rope 130311453 (``depth``): judged on 17 of 20 beads 0.2 s after the suction took the rope for another
        push, the policy was halted and the opening fell from enclosed to 55 % covered.

        Args:
            points: element id -> (k, 3) world metres, this frame.
            stale_ids: the elements stale this frame.
            unknown: ids of the constraints without a verdict because they read one of ``stale_ids``.
            obs: this frame (its time and robot state).
        Returns:
            constraint id -> its verdict on the elements seen, for those that hold.
        """
        if engaged(obs):
            return {}
        set_like = {cid for cid in unknown
                    if self._monotone.get(cid) and self._uses[cid] & stale_ids <= self._monotone[cid]}
        if not set_like:
            return {}
        H, ht = self._history.arrays()
        seen_points = {i: p for i, p in points.items() if i not in stale_ids}
        seen_history = {i: h for i, h in H.items() if i not in stale_ids}
        out: dict[str, Verdict] = {}
        for v in self.runtime.step(seen_points, seen_history, ht, obs.t):
            if v.constraint_id in set_like and v.ok and not v.fault:
                unseen = sorted(self._uses[v.constraint_id] & stale_ids)
                out[v.constraint_id] = replace(v, reason=f"{v.reason}; judged on the elements seen (unseen: {unseen})")
        return out

    def _settle(self, obs: Observation, ctx: MonitorContext) -> SubgoalEnd | None:
        """One attempt at upon verdicts on re-measured elements; up to ``settle_frames`` more frames,
        one period apart, until every upon check has a verdict that is neither a fault nor stale."""
        tr, _ = self._track(obs)
        points, stale, tracked, measured = self._refreshed(obs, tr, ctx)
        self._history.push(obs.t, points)
        stale_ids = {i for i, st in stale.items() if np.any(st)}
        self._last = (obs.t, dict(points), stale_ids, tracked, measured)
        verdicts = self._upon_verdicts(points, stale_ids, obs)
        if len(verdicts) != len(self._upon) and self._settle_attempt < self.cfg.settle_frames:
            self._settle_attempt += 1
            self._settle_next = obs.t + self._period
            return None
        self._settling = False
        ctx.emit("final_check", t=obs.t, verdicts=[v.to_dict() for v in verdicts], refreshed=self.cfg.refresh_on_done)
        if not self._upon:
            return self._end_of("success", "policy finished")
        if len(verdicts) == len(self._upon) and all(v.ok for v in verdicts):
            return self._end_of("success", "; ".join(v.reason for v in verdicts))
        bad = [v for v in verdicts if not v.ok]
        v = bad[0] if bad else None
        if v is not None:
            ctx.alarm(self._subgoal, v.constraint_id, v.phase.value, v.reason, v.t)
            return self._end_of("reactive_failure", f"{v.constraint_id}: {v.reason}")
        return self._end_of("reactive_failure", "no verdict on the upon checks (faults or lost elements)")


    # --- the task is called complete: the last subgoal's upon checks once more, on the scene at rest -------------
    def follow(self, obs: Observation) -> None:
        """Track one frame after the last subgoal ended, while the monitor waits for the scene to come to rest before
        it calls the task complete: the elements keep being followed and the history grows, so :meth:`at_rest`
        judges the scene as it settled (nothing happens without an upon check to judge)."""
        if self._unwatched or not self._upon:
            return
        tr, _ = self._track(obs)
        self._history.push(obs.t, tr.points)

    def at_rest(self, obs: Observation, ctx: MonitorContext) -> SubgoalEnd | None:
        """The last subgoal's upon checks on the scene at rest (re-measured as :meth:`_confirm` does); None when they
        hold or have no verdict (an element unseen now does not undo a completion judged before), else a reactive
        failure whose first violated check is raised as an alarm (the planner re-plans on it).

        Judged only if an element the checks read (not the robot's) moved more than ``rest_motion`` (default 0:
        any move) since the frame the completion was judged on. A bound of centimetres would keep completions the
        scene has undone: a rope bead sliding 2.6 cm down another opens the square after the halt; a book tipping
        over after the release moves its spine by centimetres."""
        if self._unwatched or not self._upon:
            return None
        judged, unseen = (self._last[1], set(self._last[2])) if self._last is not None else (None, set())
        tr, _ = self._track(obs)
        points, stale, _, measured = self._refreshed(obs, tr, ctx, confirming=True)
        self._history.push(obs.t, points)
        stale_ids = {i for i, st in stale.items() if np.any(st)}
        moved = self._moved_since(judged, points, stale_ids | unseen)
        if moved is not None and moved <= self.cfg.rest_motion:
            ctx.emit("rest_check", t=obs.t, ok=True, judged=False, moved=round(moved, 4))
            return None
        verdicts = self._upon_verdicts(points, stale_ids, obs)
        bad = [v for v in verdicts if not v.ok]
        ctx.emit("rest_check", t=obs.t, ok=not bad, judged=True, moved=None if moved is None else round(moved, 4),
                 remeasured=sorted(measured), verdicts=[v.to_dict() for v in verdicts])
        if not bad:
            return None
        v = bad[0]
        ctx.alarm(self._subgoal, v.constraint_id, v.phase.value, v.reason, obs.t)
        return self._end_of("reactive_failure", f"{v.constraint_id}: {v.reason} (once the scene came to rest after "
                                                "the subgoal ended)")

    def _moved_since(self, judged: dict[int, np.ndarray] | None, points: dict[int, np.ndarray],
                     stale_ids: set[int]) -> float | None:
        """Metres: the largest move of an element the upon checks read between ``judged`` and ``points`` (element id
        -> (k, 3) world metres), as the symmetric Hausdorff distance of its two point sets; None when no such element
        is in both. Not the robot's (it moves away after a release), not one stale now or at the completion's frame (its
        point there is where it was last seen, not a measurement: a rope bead unseen at the halt and seen again at rest
        "moved" 20 cm; ``stale_ids``), and not a part that no view saw when it was painted (its whole object stood in,
        ``ElementSupport.part_seen``: its points are not the part's, and carried with the part's turns they sweep
        centimetres while the part settles by millimetres: a rope bead painted 8 cm off at the rope's centre)."""
        if judged is None:
            return None
        skip = {e.id for e in self._elements
                if e.owner[0] == "robot" or (e.support is not None and not e.support.part_seen)}
        ids = set().union(*(self._uses[c.id] for c in self._upon)) - skip - stale_ids
        moves = []
        for i in ids:
            a, b = judged.get(i), points.get(i)
            if a is None or b is None:
                continue
            a, b = np.asarray(a, dtype=float).reshape(-1, 3), np.asarray(b, dtype=float).reshape(-1, 3)
            d = np.linalg.norm(a[:, None] - b[None], axis=2)  # (ka, kb)
            if np.all(np.isfinite(d)):  # order-free (a re-measured line's ends or surface's corners may swap)
                moves.append(float(max(d.min(axis=1).max(), d.min(axis=0).max())))
        return max(moves) if moves else None
