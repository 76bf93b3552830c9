"""The depth tracker on simulator frames: a carried, dropped and pushed block, and one hidden by the arm.

The tracker sees only the rendered depth, the cameras and the robot state; the test reads the
simulator's poses to score it (the element's painted points carried along with its block's true pose,
re-anchored whenever the hook re-paints it).
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pybullet")

from code_as_monitor.core.constraints import Action
from code_as_monitor.core.elements import ElementSpec
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, TrackerConfig, make_segmenter, make_tracker
from code_as_monitor.sim.cameras import CameraSpec
from code_as_monitor.sim.env import make_env
from code_as_monitor.sim.motion import Mover
from code_as_monitor.sim.world import WorldConfig


class Scored:
    """Runs the depth tracker on one block's element and scores every frame against the truth."""

    def __init__(self, env, obj: str, part: str = "") -> None:
        self.env, self.obj = env, obj
        self.painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
        self.spec = ElementSpec(f"{obj} {part}".strip(), obj, part)
        self.tracker = make_tracker(TrackerConfig.from_name("depth"))
        self.tracker.set_reacquire(self._repaint)
        self.calls: list[float] = []
        obs = env.world.observe()
        el = self.painter.build_element(obs, 0, self.spec)
        assert el is not None
        self._anchor(obs, el.points)
        self.tracker.reset(obs, [el])
        self.frames: list[dict] = []

    def _anchor(self, obs, points: np.ndarray) -> None:
        T = obs.object_poses[self.obj]
        self.local = (points - T[:3, 3]) @ T[:3, :3]

    def _repaint(self, obs, el):
        self.calls.append(obs.t)
        new = self.painter.build_element(obs, el.id, self.spec)
        if new is not None:
            self._anchor(obs, new.points)
        return new

    def run(self, ticks, label: str) -> list[dict]:
        """Tick the world through ``ticks`` (a generator), tracking every camera frame."""
        world = self.env.world
        out = []
        for _ in ticks:
            if not world.frame_due():
                continue
            obs = world.observe()
            res = self.tracker.step(obs)
            T = obs.object_poses[self.obj]
            truth = self.local @ T[:3, :3].T + T[:3, 3]
            out.append({"t": obs.t, "stale": bool(res.stale[0].any()), "est": res.points[0][0], "truth": truth[0],
                        "err": float(np.linalg.norm(res.points[0][0] - truth[0])),
                        "tip": obs.robot.ee_points["tip"], "label": label})
        self.frames += out
        return out


def _policy(env, action: Action):
    env.policy.start(action)
    while not env.policy.done:
        env.policy.step()
        yield


def _move(env, gen):
    for _ in gen:
        env.world.tick()
        yield


def _hold(env, seconds: float):
    for _ in range(round(seconds / env.world.dt)):
        env.world.robot.hold()
        env.world.tick()
        yield


def test_carried_dropped_and_pushed_block_are_followed():
    with make_env("stack-in-order", seed=0, disturbed=False, world_config=WorldConfig(width=320, height=240)) as env:
        world = env.world
        sc = Scored(env, "red_block")
        # Carried: picked up and moved 15 cm sideways at carry height.
        lift = sc.run(_policy(env, Action("pick", {"obj": "red_block"})), "pick")
        mover = Mover(world)
        carry = sc.run(_move(env, mover.move(world.robot.tip() + np.array([-0.05, 0.14, 0.0]))), "carry")
        held = [f for f in lift + carry if f["truth"][2] > 0.05]
        assert len(held) >= 5
        assert all(not f["stale"] and f["err"] < 0.005 for f in held), [(f["t"], f["err"]) for f in held]
        # Dropped: the suction lets go at carry height; the block falls ~12 cm and lands.
        world.robot.ee.release()
        fall = sc.run(_hold(env, 0.8), "fall")
        for f in fall:  # each frame either stale or on the falling block, never left with the gripper
            assert f["stale"] or f["err"] < 0.01, (f["t"], f["err"])
            if np.linalg.norm(f["truth"] - f["tip"]) > 0.05:
                assert f["stale"] or np.linalg.norm(f["est"] - f["tip"]) > 0.04
        assert fall[0]["truth"][2] - fall[-1]["truth"][2] > 0.08  # it did fall
        assert not fall[-1]["stale"] and fall[-1]["err"] < 0.003
        # Pushed: the suction cup comes down beside the block and sweeps 8 cm through it, over it.
        p = world.position("red_block")
        push = sc.run(_move(env, mover.move(p + np.array([0.045, 0.0, 0.10]))), "approach")
        push += sc.run(_move(env, mover.move(p + np.array([0.045, 0.0, -0.0]))), "down")
        push += sc.run(_move(env, mover.move(p + np.array([-0.08, 0.0, 0.0]), speed=0.1)), "push")
        push += sc.run(_hold(env, 0.3), "rest")
        moved = float(np.linalg.norm(push[-1]["truth"] - push[0]["truth"]))
        assert moved > 0.06, moved
        assert not push[-1]["stale"] and push[-1]["err"] < 0.005
        assert np.linalg.norm(push[-1]["est"] - push[0]["est"]) > 0.05  # followed, not left where it was
        during = [f for f in push if f["label"] == "push"]
        assert sum(f["stale"] for f in during) <= len(during) // 2
        assert all(f["stale"] or f["err"] < 0.035 for f in during), [(f["t"], f["err"]) for f in during]


def test_block_hidden_by_the_arm_is_stale_then_reacquired():
    """One top view; the hand hovers over the block for 1 s, meanwhile the block is shifted 6 cm."""
    top = [CameraSpec("top", eye=(0.5, 0.0, 1.5), target=(0.5, 0.0, 0.0), width=320, height=240, fov_y_deg=32.0)]
    import pybullet as pb

    with make_env("stack-in-order", seed=0, disturbed=False, world_config=WorldConfig(cameras=top)) as env:
        world = env.world
        sc = Scored(env, "red_block")
        mover = Mover(world)
        p = world.position("red_block")
        sc.run(_move(env, mover.move(p + np.array([0.0, 0.0, 0.12]))), "cover")
        hidden = sc.run(_hold(env, 0.5), "hidden")
        q = p + np.array([0.04, 0.045, 0.0])
        pb.resetBasePositionAndOrientation(world.body_of("red_block"), q.tolist(), [0, 0, 0, 1],
                                           physicsClientId=world.client)
        hidden += sc.run(_hold(env, 0.5), "hidden")
        assert sum(f["stale"] for f in hidden) >= 0.6 * len(hidden)
        assert all(f["stale"] or f["err"] < 0.005 for f in hidden)  # a reported point is a seen one
        away = sc.run(_move(env, mover.move(p + np.array([0.0, -0.25, 0.25]))), "away")
        away += sc.run(_hold(env, 0.5), "away")
        assert sc.calls and min(sc.calls) < away[0]["t"]  # the hook re-painted it while lost
        end = away[-1]
        assert not end["stale"] and end["err"] < 0.003
        assert np.linalg.norm(end["est"] - q) < 0.03  # where the block now is, not where it was


def test_block_painted_in_the_jaws_is_carried_from_the_first_frame():
    """The agent re-paints its elements at every subgoal's start, often with the object already held. The new body
    must count as held at once: the first frame after the paint is tried where the end-effector carried it (seen
    with slot-pen 191355131: the pen re-painted as a re-plan began swung 3.4 cm in one frame, was lost, and was
    re-found 11.6 cm off: a false "pen dropped")."""
    with make_env("stack-in-order", seed=0, disturbed=False, world_config=WorldConfig(width=320, height=240)) as env:
        world = env.world
        for _ in _policy(env, Action("pick", {"obj": "red_block"})):
            pass
        start = world.robot.tip()
        swing = _move(env, Mover(world).move(start + np.array([0.0, 0.25, 0.0]), speed=0.4))
        while not world.frame_due() or float(np.linalg.norm(world.robot.tip() - start)) < 0.04:
            next(swing)  # under way at speed: the next camera frame is centimetres on
        sc = Scored(env, "red_block")  # painted now, in the jaws
        fast = sc.run(swing, "swing")
        assert len(fast) >= 3 and float(np.linalg.norm(fast[1]["truth"] - fast[0]["truth"])) > 0.02  # fast moves
        assert all(not f["stale"] and f["err"] < 0.005 for f in fast), [
            (round(f["t"], 2), f["stale"], round(1e3 * f["err"], 1)) for f in fast]


def test_lower_block_stays_put_while_the_next_is_set_on_it():
    """The scripted stack (undisturbed): the tracked lower block must stay where it rests while the arm sets
    the next block on it and hides its top (seen with this episode seed: the estimate slid 22 mm up along
    its side faces toward the upper block's top, and the monitor read "green_block moved 0.022 m")."""
    with make_env("stack-in-order", seed=1119153100, disturbed=False,
                  world_config=WorldConfig(width=320, height=240)) as env:
        plan = env.task.default_plan()
        lower = plan[-1].args["target"]
        sc = Scored(env, lower)
        frames = []
        for action in plan:
            frames += sc.run(_policy(env, action), action.skill)
        rest = [f for f in frames if f["label"] != "pick" or f["t"] > 0]
        assert rest and all(f["stale"] or f["err"] < 0.005 for f in rest), [
            (round(f["t"], 2), round(1e3 * f["err"], 1)) for f in rest if f["err"] >= 0.005]


@pytest.mark.parametrize("seed", [47304037, 17])
def test_pen_painted_upright_is_followed_as_it_is_let_go_into_the_holder(seed):
    """The scripted slot-pen (undisturbed), the pen's tip painted at the insert's start, as the agent paints it:
    held upright above the holder, its model one side of the pen. Let go, the pen drops a centimetre and leans in
    the holder (seen with these seeds: ICP turned it 9-26 degrees from every guess and no pose passed, the pen
    was lost, its relocation failed and the tip stayed stale on every frame after the release, so the final check
    had no verdict). After the pen's lowest point the tip must be reported, on the true tip. (Seed 101 still loses it
    there: not fixed.)"""
    with make_env("slot-pen", seed=seed, disturbed=False, world_config=WorldConfig(width=320, height=240)) as env:
        sc, frames = None, []
        for action in env.task.default_plan():
            if action.skill == "insert":
                sc = Scored(env, "pen", "tip")
            if sc is None:
                for _ in _policy(env, action):  # the policy ticks the world
                    pass
            else:
                frames += sc.run(_policy(env, action), action.skill)
        lowest = int(np.argmin([f["truth"][2] for f in frames]))
        after = frames[lowest:]
        assert len(after) >= 10 and not any(f["stale"] for f in after), [f["t"] for f in after if f["stale"]]
        assert all(f["err"] < 0.008 for f in frames if not f["stale"]), [
            (round(f["t"], 2), round(1e3 * f["err"], 1)) for f in frames if not f["stale"] and f["err"] >= 0.008]


@pytest.mark.parametrize("seed", [47304037, 101])
def test_pen_tip_followed_into_the_holder_with_its_pen(seed):
    """The scripted slot-pen (undisturbed): the pen's tip (a part of the pen) hides in the holder as the pen
    goes in. Its few points must not slide up the pen's visible body (seen with seed 47304037: the
    estimate stuck at the rim, 4-5 cm above the true tip, and the monitor read "pen dropped ... not inside
    pen_holder" after the release) nor onto the holder's wall (seed 101: 3.5 cm off from the moment it entered,
    reported fresh to the end); a reported tip is on the true one, and while the held pen goes in it is
    reported where the pen carries it (not only stale)."""
    with make_env("slot-pen", seed=seed, disturbed=False, world_config=WorldConfig(width=320, height=240)) as env:
        sc = Scored(env, "pen", "tip")
        rim = float(env.world.position("pen_holder/rim")[2])  # the rim link sits at the opening's height
        frames = []
        for action in env.task.default_plan():
            frames += sc.run(_policy(env, action), action.skill)
        fresh = [f for f in frames if not f["stale"]]
        assert all(f["err"] < 0.008 for f in fresh), [(round(f["t"], 2), round(1e3 * f["err"], 1))
                                                       for f in fresh if f["err"] >= 0.008]
        deep = [f for f in frames if f["label"] == "insert" and f["truth"][2] < rim - 0.02]
        assert deep and sum(not f["stale"] for f in deep) >= len(deep) // 2
