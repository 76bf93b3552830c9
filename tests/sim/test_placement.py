"""Placing releases judged at rest (sim.placement): placed, misplaced, and the releases not to judge."""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.bench.metrics import failures
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.episode import run_open_loop
from code_as_monitor.sim.placement import JUDGE_MAX_S, REST_S


def _kinds(events, *kinds):
    return [e for e in events if e["kind"] in kinds]


def _tick(world, seconds: float) -> None:
    for _ in range(round(seconds / world.dt)):
        world.tick()


def test_a_book_stowed_standing_is_placed_at_rest():
    res = run_open_loop("stow-book", seed=0)
    assert res.success
    (rel,) = _kinds(res.events, "released")
    (judged,) = _kinds(res.events, "placed", "misplaced")
    assert judged["kind"] == "placed" and judged["obj"] == "book" and judged["t"] == rel["t"]
    assert judged["at_rest"] and judged["judged_at"] >= rel["t"] + REST_S - 1e-6


def test_a_book_let_go_lying_on_the_table_is_misplaced_at_the_release_time():
    with make_env("stow-book", seed=1) as env:
        w = env.world
        _tick(w, 0.2)  # the scene settles: the book lies flat beside the shelf
        t0 = w.t
        w.events.log(t0, "released", "book", target="bookshelf", skill="stow")
        _tick(w, 1.0)
        (m,) = _kinds(w.events.events, "placed", "misplaced")
        assert m["kind"] == "misplaced" and m["t"] == t0 and m["target"] == "bookshelf"
        assert "not" in m["reason"] or "off" in m["reason"]
        assert "after" not in m  # nothing disturbed that action
        assert [f["kind"] for f in failures(w.events.events)] == ["misplaced"]
        n = len(w.events.events)
        _tick(w, JUDGE_MAX_S + 0.5)
        assert len(_kinds(w.events.events[n:], "placed", "misplaced")) == 0  # judged once


def test_a_release_taken_again_or_moved_by_a_disturbance_is_not_judged():
    with make_env("slot-pen", seed=2) as env:
        w = env.world
        _tick(w, 0.2)
        w.events.log(w.t, "released", "pen", target="pen_holder", skill="insert")
        w.events.log(w.t, "gripper_close", "pen")
        _tick(w, 0.1)
        w.events.log(w.t, "released", "pen", target="pen_holder", skill="insert")
        w.events.log(w.t, "object_knocked", "pen")
        _tick(w, JUDGE_MAX_S + 0.2)
        assert _kinds(w.events.events, "placed", "misplaced") == []


def test_a_counterfactual_rollout_leaves_no_judgement_behind():
    with make_env("stow-book", seed=1) as env:
        w = env.world
        _tick(w, 0.2)
        token = w.save_state()
        w.events.log(w.t, "released", "book", target="bookshelf", skill="stow")
        _tick(w, 0.6)
        assert len(_kinds(w.events.events, "misplaced")) == 1  # judged inside the rollout
        w.restore_state(token)
        _tick(w, JUDGE_MAX_S + 0.2)
        assert _kinds(w.events.events, "released", "placed", "misplaced") == []


@pytest.mark.parametrize("seed", [0, 1])
def test_a_book_tilted_in_the_grasp_and_stowed_open_loop_is_misplaced_after_that_disturbance(seed):
    res = run_open_loop("stow-book", seed=seed, disturbance="b")
    assert not res.success
    (pert,) = _kinds(res.events, "grasp_perturbed")
    (m,) = _kinds(res.events, "misplaced")
    assert m["after"] == {"t": pert["t"], "kind": "grasp_perturbed", "obj": "book"}
    (f,) = failures(res.events)  # one failure: the disturbance, with the misplacement merged into it
    assert f["kind"] == "grasp_perturbed" and f["objects"] == ["book", "book"]


def test_the_pen_let_go_in_the_holder_is_placed_and_one_beside_it_is_misplaced():
    res = run_open_loop("slot-pen", seed=0)
    assert res.success
    assert [e["kind"] for e in _kinds(res.events, "placed", "misplaced")] == ["placed"]
    with make_env("slot-pen", seed=0) as env:
        w = env.world
        _tick(w, 0.2)
        w.events.log(w.t, "released", "pen", target="pen_holder", skill="insert")
        _tick(w, 1.0)
        (m,) = _kinds(w.events.events, "placed", "misplaced")
        assert m["kind"] == "misplaced"
        assert np.isfinite(m["judged_at"])
