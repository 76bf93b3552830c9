"""The depth tracker's re-acquisition when a weak re-paint arrives: the known model, relocated onto the re-paint's
segmentation, keeps its elements where they are on the object (:func:`~code_as_monitor.perception.trackers.
depth_relocate.keep_known`), also when the object now shows too little of itself for tracking's own bar."""

from __future__ import annotations

import numpy as np
import pytest
from perception_synth import Box, Scene, camera, observe

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.perception.trackers.base import DepthTrackerConfig, make_tracker
from code_as_monitor.perception.trackers.depth_body import RigidBody
from code_as_monitor.perception.trackers.depth_relocate import SEGMENT_SHARE, share_on_model
from code_as_monitor.perception.trackers.depth_search import BodyState

CAMS = [camera("front", (0.55, -0.05, 0.55), (0.0, 0.0, 0.08), fov=60.0),
        camera("side", (0.04, 0.5, 0.45), (0.0, 0.0, 0.08), fov=60.0)]
WALL = {"color": (150, 110, 60), "textured": False}


def _shelf(height: float) -> list[Box]:
    """A slot 3 cm wide at x = 0.08 (inner walls at x 0.055 / 0.105), its floor 3 cm up, walls ``height`` m tall."""
    return [Box("shelf_a", np.array([0.05, 0.0, height / 2]), np.array([0.01, 0.19, height]), **WALL),
            Box("shelf_b", np.array([0.11, 0.0, height / 2]), np.array([0.01, 0.19, height]), **WALL),
            Box("shelf_c", np.array([0.08, -0.09, height / 2]), np.array([0.05, 0.01, height]), **WALL),
            Box("shelf_d", np.array([0.08, 0.09, height / 2]), np.array([0.05, 0.01, height]), **WALL),
            Box("shelf_e", np.array([0.08, 0.0, 0.015]), np.array([0.05, 0.17, 0.03]), **WALL)]


def _stow(min_seen_frac: float) -> tuple[list[np.ndarray], list]:
    """A 3 x 15 x 20 cm book standing on the table, held 1 cm below its top under a 5 x 3 cm palm, is painted, carried
    up out of both views, across and down into the slot, whose walls leave its top centimetre in view. Returns each
    frame's error of the tracked book centre against the painted one carried with the book (3,), and the re-paints."""
    book = Box("book", np.array([-0.08, 0.0, 0.10]), np.array([0.03, 0.15, 0.20]), color=(40, 40, 200), textured=False)
    palm = Box("palm", np.zeros(3), np.array([0.05, 0.03, 0.02]), color=(90, 90, 90), textured=False)
    scene = Scene([book, palm, *_shelf(0.21)], table_textured=False)

    def obs(t: float):
        palm.center = book.center + np.array([0.0, 0.0, 0.11])
        o = observe(scene, CAMS, t, tip=book.center + np.array([0.0, 0.0, 0.09]), with_poses=False)
        o.robot.ee_pose[:3, :3] = np.diag([1.0, -1.0, -1.0])  # a tool pointing down
        o.robot.gripper = 1.0
        return o

    spec = ElementSpec("book centre", "book", "", "point")
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    o0 = obs(0.0)
    el = painter.build_element(o0, 0, spec)
    assert el is not None
    tracker = make_tracker(DepthTrackerConfig(min_seen_frac=min_seen_frac))
    tracker.reset(o0, [el])
    repaints: list = []

    def hook(o, old):
        repaints.append(painter.build_element(o, old.id, spec))
        return repaints[-1]

    tracker.set_reacquire(hook)
    painted = el.points[0] - book.center
    path = [np.array([-0.08, 0.0, 0.10 + 0.25 * k]) for k in range(1, 5)]
    path += [np.array([0.08, 0.0, z]) for z in (0.82, 0.57, 0.32)] + [np.array([0.08, 0.0, 0.13])] * 6
    errors = []
    for f, centre in enumerate(path, 1):
        book.center = centre
        res = tracker.step(obs(0.1 * f))
        errors.append(None if res.stale[0].any() else res.points[0][0] - (centre + painted))
    return errors, repaints


def test_a_weak_repaint_of_a_book_in_its_shelf_keeps_the_known_model():
    """The tracker's bar is raised (half the points seen at paint time) so that the top centimetre the slot leaves in
    view cannot pass it, as the simulator's book lowered into its shelf could not (34 of 473 points seen). The book is
    lost on the way, re-painted in the slot from its top alone (a weak paint: its hidden side assumed, centimetres
    high), and the known model, relocated on the re-paint's segmentation, brings the painted centre back within
    5 mm; before, the weak re-paint became the model (8.6 cm high)."""
    errors, repaints = _stow(min_seen_frac=0.5)
    assert any(e is None for e in errors[:8])  # lost on the way down
    assert repaints and repaints[-1] is not None and repaints[-1].support.weak()
    off = repaints[-1].points[0] - np.array([0.08, 0.0, 0.13])
    assert np.linalg.norm(off) > 0.02  # the weak re-paint itself is centimetres off
    assert errors[-1] is not None, "the book in its shelf stayed stale"
    assert np.linalg.norm(errors[-1]) < 0.005, errors[-1]


def test_share_on_model_counts_the_segmentation_on_the_posed_model():
    """All of a model's own points lie on it; moved 50 cm away, none do; a third of them with all the moved ones: a
    quarter."""
    P = np.array([[x, y, z] for x in np.linspace(0, 0.1, 11) for y in np.linspace(0, 0.1, 11) for z in (0.0, 0.05)])
    body = BodyState(("box", ""), RigidBody(P, 0.005, None, 0.0))
    model = body.model
    assert model is not None
    T = np.eye(4)
    assert share_on_model(body, T, model.points, 0.01) == pytest.approx(1.0)
    T_far = np.eye(4)
    T_far[:3, 3] = [0.0, 0.0, 0.5]
    assert share_on_model(body, T_far, model.points, 0.01) == 0.0
    far = model.points + np.array([0.0, 0.0, 0.5])
    mixed = np.vstack([model.points[: len(far) // 3], far[: len(far)]])
    assert share_on_model(body, T, mixed, 0.01) == pytest.approx((len(far) // 3) / len(mixed))
    assert share_on_model(body, T, np.zeros((0, 3)), 0.01) == 0.0
    assert 0.5 < SEGMENT_SHARE < 1.0


def test_a_book_stowed_in_its_shelf_is_not_read_as_dropped_with_depth():
    """Stow-book (b) 1822091572 with the depth tracker (kb planner, sim masks): the held book, carried fast out of view
    and lowered into the shelf, was lost; its weak re-paint from the top the slot leaves in view became its model,
    4.5 cm off, its spine stayed stale, and the stowed book read "dropped ... not in the slot of bookshelf": a re-grasp
    out of the shelf, then stuck. Its known model, relocated, now keeps it where it is. The same episode guards the
    painter's few-pixel rule (:mod:`code_as_monitor.painter.mask_elements`): the book's cover shown by 4-7 pixels as it
    sinks into the shelf, with sides unbounded, painted from those pixels alone (44 mm off) broke it again."""
    pytest.importorskip("pybullet")
    import pybullet as pb

    from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop

    cfg = ClosedLoopConfig(task="stow-book", seed=1822091572, task_params={"disturbance": "b"}, tracker="depth",
                           video=False, max_replans=10, deadline_s=0.5)
    env: list = []
    truth: dict[float, np.ndarray] = {}  # the book's true position at every frame the monitor took

    def on_obs(obs, _done) -> None:
        w = env[0].world
        truth[round(obs.t, 3)] = np.asarray(pb.getBasePositionAndOrientation(w.body_of("book"),
                                                                            physicsClientId=w.client)[0])

    summary = run_closed_loop(cfg, on_env=env.append, on_observation=on_obs)
    assert summary["success"], summary["reason"]
    # the book really leaves the gripper short of the shelf (about 7 s, in the simulator too) and may be read so;
    # a book standing in its slot (within 5 cm of where it ends, stowed) is never read as "not in the slot"
    stowed = truth[max(truth)]
    in_slot = [a for a in summary["episode"]["alarms"] if "not in the slot" in a["reason"]
               and np.linalg.norm(truth[min(truth, key=lambda t: abs(t - a["t"]))] - stowed) < 0.05]
    assert not in_slot, in_slot
