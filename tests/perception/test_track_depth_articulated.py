"""The depth tracker on an articulated object: a drawer pulled open by its handle, its cabinet's frame at rest.

The agent paints the handle, the drawer and the frame as parts of one object (the cabinet), so the tracker also
registers the whole cabinet as their parent. Pulled by the handle, that rigid whole follows the grip (the tip is
at its handle points) while only the drawer moves; the frame must not be dragged along with it, and the handle must
stay in the jaws. Scored against the simulator's part poses (read by the test only), and in the closed loop.
"""

from __future__ import annotations

import numpy as np
import pytest
from sim_tracking import tracked_frames

pytest.importorskip("pybullet")

from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, TrackerConfig, make_segmenter, make_tracker
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.world import WorldConfig

PARTS = ("handle", "drawer", "frame")


def _track_pull(seed: int) -> list[dict]:
    """Grasp, paint the three parts, then pull while tracking; per frame and part the error against the truth."""
    with make_env("open-drawer", seed=seed, disturbed=False, world_config=WorldConfig(width=320, height=240)) as env:
        world = env.world
        painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
        tracker = make_tracker(TrackerConfig.from_name("depth"))
        plan = env.task.default_plan()
        for action in plan[:1]:  # the grasp: the agent paints the pull's elements when it starts
            env.policy.start(action)
            while not env.policy.done:
                env.policy.step()
        obs = world.observe()
        els, local = [], []
        for i, part in enumerate(PARTS):
            el = painter.build_element(obs, i, ElementSpec(f"drawer cabinet {part}", "drawer_cabinet", part))
            assert el is not None, part
            T = obs.object_poses[f"drawer_cabinet/{part}"]
            els.append(el)
            local.append((el.points - T[:3, 3]) @ T[:3, :3])
        tracker.reset(obs, els)
        frames = []
        for action in plan[1:]:
            for obs, res in tracked_frames(env, action, tracker):
                for i, part in enumerate(PARTS):
                    T = obs.object_poses[f"drawer_cabinet/{part}"]
                    truth = local[i] @ T[:3, :3].T + T[:3, 3]
                    frames.append({"t": obs.t, "part": part, "stale": bool(res.stale[i].any()),
                                   "err": float(np.linalg.norm(res.points[i].mean(axis=0) - truth.mean(axis=0)))})
        return frames


@pytest.mark.parametrize("seed", [0, 826441446])
def test_frame_stays_while_the_drawer_is_pulled_by_its_handle(seed):
    frames = _track_pull(seed)
    by = {p: [f for f in frames if f["part"] == p] for p in PARTS}
    assert len(by["frame"]) >= 10
    bad = {p: [(round(f["t"], 1), round(1e3 * f["err"], 1)) for f in fs if not f["stale"] and f["err"] >= 0.01]
           for p, fs in by.items()}
    assert not any(bad.values()), bad
    for p in ("handle", "frame"):  # the drawer's own few visible points may be hidden by the arm at times
        stale = sum(f["stale"] for f in by[p])
        assert stale <= 0.1 * len(by[p]), (p, stale, len(by[p]))


def test_drawer_slip_episode_with_depth_recovers_after_the_regrasp():
    """Drawer-slip 826441446 with the depth tracker (kb planner, sim masks): after the slip and the re-grasp, the
    whole cabinet, held through its handle, was dragged by the pull; the static frame was put where the dragged
    cabinet carried it (its own unmoved registration counted as sliding along the cabinet), and once the cabinet
    was lost the handle left the jaws for a pose 3.3 cm back on the drawer's front: "the grasp slipped off the
    handle" on every pull to the re-plan bound. The frame now keeps its own pose and the handle its carry."""
    from code_as_monitor.bench.closed_loop import ClosedLoopConfig, run_closed_loop

    cfg = ClosedLoopConfig(task="open-drawer", seed=826441446, task_params={"disturbance": "slip"}, tracker="depth",
                           video=False, max_replans=3, deadline_s=0.5)
    summary = run_closed_loop(cfg)
    pulls = [s for s in summary["episode"]["subgoals"] if s["skill"] == "pull"]
    assert summary["success"], summary["reason"]
    assert len(pulls) == 2 and pulls[0]["outcome"] == "violated" and pulls[1]["outcome"] == "success", pulls
