"""Wait for the scene to come to rest before re-planning after a failure.

After a halt or a failed subgoal the world may still be moving: a dropped pen is still falling over, a
pushed block still sliding. A subgoal planned on that frame aims at where the object was, and its own
"stays where it lies" checks then fire on the object's remaining motion (slot-pen: 2-4 ``steady_pen`` alarms
within 0.5 s of every drop, their open-loop continuations often fine). The robot is halted, so what still
changes in the depth images is the scene. :class:`RestWait` says when it has stopped changing: the scene is at
rest after ``still_frames`` monitored frames in a row each of which, in every view, differs from the frame that began
the streak on at most ``moved_frac`` of the pixels by more than ``depth_tol`` metres (and the ``min_moved`` pixel
floor: sensor noise flickers single pixels); a frame that differs more begins a new streak. Against the streak's first
frame, not the previous one: a slow slide (3 cm/s is 3 mm a frame at 10 Hz) adds up. A noisy depth camera raises
the per-pixel tolerance to ``noise_k`` times the view's depth noise, estimated from the two frames (1.4826 x the
median absolute difference over the pixels with a reading in both: most of a halted scene does not move; per depth
band, as noise grows with distance), when that exceeds ``depth_tol``; noise-free depth (a simulator) leaves it at
``depth_tol``. The wait ends at ``max_s`` seconds in any case (a conveyor, a person walking by: the scene may never
rest).

Not while the robot holds something (:func:`in_hand`): a halted hand keeps what it holds as it is, and waiting
can only let that get worse (a teapot halted tipped forward: its tea runs into the spout while the monitor
waits for it to stop moving); the monitor then re-plans at once, as without the wait.

Perception only: the depth images the monitor already receives, no element, tracker or simulator pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from code_as_monitor.core.checks import check_count, check_range
from code_as_monitor.core.observation import Observation, RobotState


@dataclass(frozen=True)
class RestWait:
    """When the scene counts as at rest (see the module docstring).

    Attributes:
        max_s: longest wait in observation seconds; 0 disables the wait (re-plan on the failing frame).
        period_s: seconds between the frames compared (the monitoring period).
        still_frames: consecutive still comparisons needed.
        depth_tol: metres of depth change above which a pixel counts as moved.
        moved_frac: share of a view's pixels (with a reading in both frames) that may move in a still frame.
        min_moved: moved pixels always allowed per view (isolated noise), whatever the resolution.
        noise_k: the per-pixel tolerance is at least this many times the depth noise estimated from the two frames
            (5: independent Gaussian noise then moves one pixel in about 1.7 million); 0 keeps ``depth_tol``.
    """

    max_s: float = 1.5
    period_s: float = 0.1
    still_frames: int = 2
    depth_tol: float = 0.005
    moved_frac: float = 0.0005
    min_moved: int = 8
    noise_k: float = 5.0

    def __post_init__(self) -> None:
        for name in ("max_s", "depth_tol", "moved_frac", "noise_k"):
            check_range("RestWait", name, getattr(self, name), 0.0, None)
        check_range("RestWait", "period_s", self.period_s, 0.0, None, lo_open=True)
        check_count("RestWait", "still_frames", self.still_frames, 1)
        check_count("RestWait", "min_moved", self.min_moved, 0)

    @property
    def enabled(self) -> bool:
        return self.max_s > 0

    @staticmethod
    def depths(obs: Observation) -> dict[str, np.ndarray]:
        """Each view's depth image, (H, W) float32 metres, read now (a simulator renders a view when first
        read, and only before its world steps again; the wait compares a frame with a later one)."""
        return {name: np.array(v.depth, dtype=np.float32) for name, v in obs.views.items()}

    def moved_pixels(self, before: dict[str, np.ndarray], now: dict[str, np.ndarray]) -> dict[str, tuple[int, int]]:
        """Per view present in both depth sets (see :meth:`depths`) with equal image sizes: (moved pixels,
        pixels with a reading in both). Views that changed size or appeared are skipped (nothing to compare)."""
        out: dict[str, tuple[int, int]] = {}
        for name, d1 in now.items():
            d0 = before.get(name)
            if d0 is None or d0.shape != d1.shape:
                continue
            ok = np.isfinite(d0) & np.isfinite(d1) & (d0 > 0) & (d1 > 0)
            diff = np.abs(d1[ok] - d0[ok])
            out[name] = (int(np.count_nonzero(diff > self.tolerance(diff, d0[ok]))), int(diff.size))
        return out

    def tolerance(self, diff: np.ndarray, depth: np.ndarray | None = None) -> np.ndarray | float:
        """Metres of depth change above which a pixel counts as moved, given one view's absolute depth differences
        ``diff`` (N,) over the pixels with a reading in both frames: ``depth_tol``, or ``noise_k`` times the noise
        estimated from them (1.4826 x their median: the standard deviation of the difference for Gaussian noise,
        robust to the pixels that did move) when that is larger. With ``depth`` (N,) metres, the noise is estimated
        per eighth of the pixels by depth (a depth camera's noise grows with distance): (N,) tolerances."""
        if self.noise_k <= 0 or diff.size == 0:
            return self.depth_tol
        if depth is None or diff.size < NOISE_BANDS * 16:
            return max(self.depth_tol, self.noise_k * 1.4826 * float(np.median(diff)))
        edges = np.quantile(depth, np.linspace(0.0, 1.0, NOISE_BANDS + 1)[1:-1])
        band = np.searchsorted(edges, depth)
        sigma = np.array([np.median(diff[band == b]) if np.any(band == b) else 0.0 for b in range(NOISE_BANDS)])
        return np.maximum(self.depth_tol, self.noise_k * 1.4826 * sigma[band])

    def still(self, before: dict[str, np.ndarray], now: dict[str, np.ndarray]) -> bool:
        """Whether nothing moved between two frames' depths (every compared view within the allowance)."""
        for moved, valid in self.moved_pixels(before, now).values():
            if moved > max(self.min_moved, self.moved_frac * valid):
                return False
        return True


class RestWatch:
    """One wait for rest under ``rule`` (a :class:`RestWait`), begun on ``obs``: feed it the frames that are
    :meth:`due`; :meth:`observe` says when the wait is over (at rest, or ``max_s`` waited).

    Attributes:
        t0: observation seconds the wait began.
        next_t: the earliest time of the next frame compared (one monitoring period after the last).
        still: still comparisons in a row; ``at_rest`` once they reach ``rule.still_frames``.
        moved: whether any compared frame differed from its streak's first (the scene moved during the wait).
        waited: seconds from ``t0`` to the last frame compared.
    """

    def __init__(self, rule: RestWait, obs: Observation) -> None:
        self.rule = rule
        self.t0 = obs.t
        self.next_t = obs.t + rule.period_s
        self._ref: dict[str, np.ndarray] | None = rule.depths(obs)  # the depths that began the still streak
        self.still, self.moved, self.waited = 0, False, 0.0

    @property
    def at_rest(self) -> bool:
        return self.still >= self.rule.still_frames

    def due(self, t: float) -> bool:
        """Whether a frame at ``t`` seconds is compared (frames between monitoring periods are not)."""
        return t + 1e-9 >= self.next_t

    def observe(self, obs: Observation) -> bool:
        """Compare a due frame with the streak's first (a slow slide adds up against it); True when the wait is over."""
        self.next_t = obs.t + self.rule.period_s
        now = self.rule.depths(obs)
        if self._ref is not None and self.rule.still(self._ref, now):
            self.still += 1
        else:
            self._ref, self.still, self.moved = now, 0, True
        self.waited = obs.t - self.t0
        return self.at_rest or self.waited + 1e-9 >= self.rule.max_s


NOISE_BANDS = 8
"""Depth bands (equal pixel counts) in which :meth:`RestWait.tolerance` estimates the depth noise separately."""

NO_WAIT = RestWait(max_s=0.0)

HOLD_DIST = 0.05
"""Metres: an object's element this close to the closed gripper's (or active suction cup's) tip may be in hand (the
knowledge base's loosest "still attached" distance)."""
HOLD_WINDOW_S = 1.0
"""Seconds of judged frames over which a held element must have moved with the tip."""
MIN_TRAVEL = 0.02
"""Metres: a tip that travelled less over the window tells nothing; nearness alone decides."""


def in_hand(robot: RobotState | None, positions: dict[int, np.ndarray], owners: dict[int, str],
            before: tuple[np.ndarray, dict[int, np.ndarray]] | None = None, hold_dist: float = HOLD_DIST) -> bool:
    """Whether the robot holds an object: its gripper is closed (suction on), the centroid of some element of an
    object other than the robot lies within ``hold_dist`` of the end effector's tip (``ee_points["tip"]``, else the
    ``ee_pose`` origin), and, when the tip travelled at least :data:`MIN_TRAVEL` since ``before``, that element moved
    with it (its displacement within half the tip's of the tip's): a holder the fingers hover over is near the tip
    but stays where it is.

    Args:
        robot: the robot's state now.
        positions: element id -> (k, 3) world points now (fresh ones only).
        owners: element id -> the object it belongs to.
        before: (tip (3,), element id -> centroid (3,)) at an earlier judged frame (about a second ago), or None.
    """
    if robot is None or robot.gripper < 0.5:
        return False
    tip = robot.tip
    near: dict[int, np.ndarray] = {}
    for i, pts in positions.items():
        if owners.get(i, "robot") == "robot" or pts is None:
            continue
        c = np.asarray(pts, dtype=float).reshape(-1, 3).mean(axis=0)
        if np.all(np.isfinite(c)) and float(np.linalg.norm(c - tip)) <= hold_dist:
            near[i] = c
    if not near:
        return False
    if before is None:
        return True
    tip0, cents0 = before
    travel = tip - np.asarray(tip0, dtype=float)
    if float(np.linalg.norm(travel)) < MIN_TRAVEL:
        return True
    for i, c in near.items():
        c0 = cents0.get(i)
        if c0 is not None and float(np.linalg.norm((c - c0) - travel)) <= 0.5 * float(np.linalg.norm(travel)):
            return True
    return False


__all__ = ["HOLD_DIST", "HOLD_WINDOW_S", "MIN_TRAVEL", "NOISE_BANDS", "NO_WAIT", "RestWait", "RestWatch", "in_hand"]
