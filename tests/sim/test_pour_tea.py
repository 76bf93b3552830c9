"""pour-tea: scene contract, the tea bookkeeping and success checker on constructed particle positions, open loop
with and without disturbances, and the painter's lid SURFACE normal against the pot's ground-truth up axis on
simulator frames.

Open-loop runs take about 4-5 s each on 2 cores (the task's world runs 100 solver iterations)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from code_as_monitor.core import ElementKind, ElementSpec
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.episode import run_open_loop
from code_as_monitor.sim.tasks.pour_tea import CUP_TOP, SPOUT_BASE, SPOUT_SLOPE, poured_ok, tea_state


def _pose(x: float, y: float, pitch_deg: float = 0.0) -> np.ndarray:
    """A base pose at (x, y, 0) turned ``pitch_deg`` about its y axis (positive: its +x, the spout, goes down)."""
    a = math.radians(pitch_deg)
    T = np.eye(4)
    T[:3, :3] = [[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]]
    T[:3, 3] = [x, y, 0.0]
    return T


POT, CUP = _pose(0.45, 0.14), _pose(0.47, -0.16)


def _at(T: np.ndarray, local) -> np.ndarray:
    return T[:3, :3] @ np.asarray(local, float) + T[:3, 3]


def test_tea_state_on_constructed_particles():
    along = SPOUT_BASE + 0.05 * np.array([math.cos(SPOUT_SLOPE), 0.0, math.sin(SPOUT_SLOPE)])
    tipped = _pose(0.45, 0.14, 60.0)
    pts = np.array([
        _at(POT, [0.0, 0.0, 0.012]),  # on the pot's floor
        _at(POT, along + np.array([0.0, 0.0, 0.008])),  # in the spout trough
        _at(tipped, [-0.03, 0.02, 0.02]),  # in a pot tipped 60 degrees
        _at(CUP, [0.01, -0.02, 0.012]),  # on the cup's floor
        _at(CUP, [0.0, 0.0, CUP_TOP + 0.01]),  # heaped 1 cm above the rim
        _at(CUP, [0.06, 0.0, 0.006]),  # on the table beside the cup
        [0.2, 0.3, 0.006],  # on the table far away
    ])
    labels = tea_state(pts[:2], POT, CUP).tolist() + tea_state(pts[2:3], tipped, CUP).tolist()
    labels += tea_state(pts[3:], POT, CUP).tolist()
    assert labels == ["pot", "pot", "pot", "cup", "cup", "spilled", "spilled"]


@pytest.mark.parametrize(("cup", "spilled", "ok"), [
    (15, 0, True),  # half in the cup, the rest still in the pot
    (14, 0, False),  # less than half
    (24, 6, True),  # a fifth spilled
    (23, 7, False),  # more than a fifth spilled
])
def test_poured_ok_fractions(cup, spilled, ok):
    state = np.array(["cup"] * cup + ["spilled"] * spilled + ["pot"] * (30 - cup - spilled))
    assert poured_ok(state)[0] is ok


def test_pour_tea_scene_contract():
    with make_env("pour-tea", seed=3) as env:
        w = env.world
        obs = w.observe()
        assert {"teapot/body", "teapot/spout", "teapot/lid", "teapot/handle", "teacup/rim"} <= set(obs.object_poses)
        labels = set().union(*(set(v.seg_labels.values()) for v in obs.views.values()))
        assert {("teapot", "body"), ("teapot", "spout"), ("teapot", "lid"), ("teapot", "handle"),
                ("teacup", "rim")} <= labels
        assert not any(o == "tea" for o, _ in labels)  # the tea is no object
        assert abs(w.position("teapot")[2]) < 0.003 and w.pose("teapot")[2, 2] > math.cos(math.radians(1.0))
        assert set(env.task.tea_labels(w)) == {"pot"}
        env.policy.start(env.plan[0])
        for _ in range(20):
            env.policy.step()
        assert w.t == pytest.approx(0.5)
        assert not env.evaluate().success


def test_pour_tea_rejects_an_unknown_disturbance():
    with pytest.raises(ConfigError, match="disturbance"):
        make_env("pour-tea", seed=0, disturbance="spill")


def test_pour_tea_open_loop_succeeds_undisturbed_and_fails_under_a_and_c():
    res = run_open_loop("pour-tea", seed=0)
    assert res.success, res.reason
    assert res.info["in_cup"] >= 25
    for d, kind in (("a", "grasp_perturbed"), ("c", "pour_undone")):
        res = run_open_loop("pour-tea", seed=0, disturbance=d)
        assert not res.success, d
        assert kind in {e["kind"] for e in res.events}, d


@pytest.mark.slow
def test_pour_tea_sideways_tilt_is_no_task_failure_open_loop():
    """(b) is a violation of "keep it level", not a task failure here: the lid keeps the tea in and the funnel spout
    pours it into the cup all the same (documented in the task; this pins the fact)."""
    res = run_open_loop("pour-tea", seed=0, disturbance="b")
    assert "grasp_perturbed" in {e["kind"] for e in res.events}
    assert res.success, res.reason


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(10))
def test_pour_tea_open_loop_undisturbed_over_seeds(seed):
    assert run_open_loop("pour-tea", seed=seed).success


def _lid_error_deg(obs, world) -> float:
    """Angle (degrees) between the painted lid SURFACE's normal and the pot's ground-truth up axis."""
    from code_as_monitor.geometry.helpers import normal
    from code_as_monitor.painter import Painter
    from code_as_monitor.perception import SegmenterConfig, make_segmenter

    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    el = painter.build_element(obs, 0, ElementSpec("teapot lid", "teapot", "lid", ElementKind.SURFACE))
    assert el is not None and el.kind is ElementKind.SURFACE
    c = abs(float(np.dot(normal(el.points), world.pose("teapot")[:3, 2])))
    return math.degrees(math.acos(min(1.0, c)))


def test_painter_lid_normal_within_3_degrees():
    with make_env("pour-tea", seed=0) as env:
        w, pol = env.world, env.policy
        assert _lid_error_deg(w.observe(), w) < 3.0  # standing on the table
        pol.start(env.plan[0])
        while not pol.done:
            pol.step()
        assert w.robot.ee.holding == w.body_of("teapot")
        assert _lid_error_deg(w.observe(), w) < 3.0  # held in the gripper


@pytest.mark.slow
def test_painter_lid_normal_within_3_degrees_tilted_to_pour():
    with make_env("pour-tea", seed=1) as env:
        w, pol = env.world, env.policy
        for a in env.plan[:3]:
            pol.start(a)
            while not pol.done:
                pol.step()
        assert math.degrees(math.acos(w.pose("teapot")[2, 2])) > 50.0
        assert _lid_error_deg(w.observe(), w) < 3.0
