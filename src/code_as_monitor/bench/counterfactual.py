"""Counterfactual rollouts for proactive alarms: would the predicted failure have happened?

At a proactive alarm (an alarm raised by a constraint marked ``proactive``, e.g. "the green block is
off-centre, so the next block will topple the tower"), :func:`rollout` snapshots the simulator
(:meth:`World.save_state` plus the Python-side state of the task, the disturbances and the scripted
policy), lets the open-loop policy go on WITHOUT the monitor for ``horizon_s`` seconds — first the
action in progress, then the rest of the task's fixed plan after it — and records whether the
predicted failure happened, while the monitored episode waits where it was.

One rule confirms a prediction for every task: the open-loop continuation ends with the task failed. The
rest of the plan runs to its end within the horizon, the world settles for :data:`SETTLE_S`, and the
task's success check fails. No new disturbance starts during the rollout (``world.disturbances_paused``):
the question is what the state at the alarm leads to if nothing is done, not what a fresh drop would do.
Lead = the first predicted failure event of the rollout (:data:`PREDICTED_KINDS`, a toppling tower) if one
happened, else the time the failed plan ended, minus the alarm's time. A rollout whose plan does not end
within the horizon confirms nothing.

Nothing of the rollout leaks into the episode. Where the operating system can fork (``isolation="fork"``,
the default on Linux), the rollout runs in a forked copy of this process (the physics client, the task, the
disturbances and the policy with its in-flight action are all copies) and only its result comes back; the
episode's own world is never stepped or restored. Measured before this existed: restoring PyBullet's saved
state in place after a rollout is not exact with a gripper holding an object (slot-pen (a), seed 1639494391:
a rollout at t = 5 s moved the rest of the episode by 59 mm, where saving and restoring without stepping
moved it by 0.002 mm). ``isolation="restore"`` (the fallback where ``os.fork`` is missing) is that in-place
method: physics, clock, event log (truncated, and its file mirror paused), disturbance random generators
and the task's consequence detectors are restored, but not the policy's in-flight action (a Python
generator; every alarm is followed by a halt or a new action, which discards it) nor PyBullet's contact
state.
"""

from __future__ import annotations

import copy
import json
import os
import select
import signal
import time
from typing import Any

import numpy as np

PREDICTED_KINDS = ("tower_collapsed", "object_knocked")
"""Ground-truth event kinds that time a confirmed prediction (the failure happened then, before the plan's
end); they do not confirm anything by themselves."""

DEFAULT_HORIZON_S = 15.0
SETTLE_S = 1.0
"""Seconds the world runs after the plan ends before a ``task_failure`` rollout is judged."""

ISOLATIONS = ("fork", "restore")
"""How a rollout is kept out of the episode (see the module docstring)."""

FORK_WALL_S = 600.0
"""Wall seconds a forked rollout may take before it is killed and the rollout is run in place instead."""

_PLAIN = (int, float, bool, str, type(None), dict, list, tuple, set, np.ndarray, np.random.Generator)


def _policy_chain(policy: Any) -> list[Any]:
    chain = [policy]
    while hasattr(chain[-1], "inner"):
        chain.append(chain[-1].inner)
    return chain


def _stateful(env: Any) -> list[Any]:
    """Python objects whose plain attributes hold episode state (task, disturbances, policy layers)."""
    objs: list[Any] = [env.task]
    for hook in env.world.tick_hooks:
        owner = getattr(hook, "__self__", None)
        if owner is not None and owner not in objs:
            objs.append(owner)
    for layer in _policy_chain(env.policy):
        for o in (layer, getattr(layer, "noise", None), getattr(layer, "mover", None)):
            if o is not None and o not in objs:
                objs.append(o)
    return objs


def _snapshot(objs: list[Any]) -> list[tuple[Any, dict[str, Any]]]:
    return [(o, {k: copy.deepcopy(v) for k, v in vars(o).items() if isinstance(v, _PLAIN)}) for o in objs]


def _restore(snap: list[tuple[Any, dict[str, Any]]]) -> None:
    for o, attrs in snap:
        for k, v in attrs.items():
            setattr(o, k, v)


def _remaining_plan(env: Any) -> list[Any]:
    """The plan's actions after the one the policy is doing now (matched by skill and object)."""
    current = getattr(_policy_chain(env.policy)[-1], "action", None)
    if current is None:
        return list(env.plan)
    for i, a in enumerate(env.plan):
        if a.skill == current.skill and a.args.get("obj") == current.args.get("obj"):
            return list(env.plan[i + 1:])
    return []


def default_isolation() -> str:
    """``fork`` where the operating system has it, else ``restore``."""
    return "fork" if hasattr(os, "fork") else "restore"


def rollout(env: Any, horizon_s: float = DEFAULT_HORIZON_S, kinds: tuple[str, ...] = PREDICTED_KINDS,
            isolation: str | None = None) -> dict[str, Any]:
    """Continue open loop from now for at most ``horizon_s`` seconds, apart from the episode; returns what
    happened.

    ``isolation``: ``fork`` (a forked copy of this process runs it), ``restore`` (run here, then restore) or
    None (:func:`default_isolation`). A forked rollout that fails to report within :data:`FORK_WALL_S` is run
    in place instead.

    Returns ``{"confirmed": bool, "event": the failure that timed it or None, "lead_s": its time - now or None,
    "horizon_s": ..., "success_at_end": the task's evaluation at the end, "plan_ended": bool}``.
    """
    how = isolation or default_isolation()
    if how not in ISOLATIONS:
        raise ValueError(f"rollout: isolation must be one of {', '.join(ISOLATIONS)}, got {how!r}")
    if how == "fork":
        forked = _forked(env, horizon_s, kinds)
        if forked is not None:
            return forked
    return _in_place(env, horizon_s, kinds)


def _continue(env: Any, horizon_s: float, kinds: tuple[str, ...]) -> dict[str, Any]:
    """Run the open-loop continuation on ``env`` itself (no restore) and judge it."""
    world, policy = env.world, env.policy
    t_alarm = world.t
    n_events = len(world.events.events)
    plan_end: float | None = None
    end = t_alarm + horizon_s
    plan = _remaining_plan(env)
    while world.t < end - 1e-9:
        if policy.done:
            if not plan:
                plan_end = world.t if plan_end is None else plan_end
                if world.t >= plan_end + SETTLE_S - 1e-9:
                    break
                policy.step()
            else:
                policy.start(plan.pop(0))
        else:
            policy.step()
    success = bool(env.evaluate().success)
    found = next((e for e in world.events.events[n_events:] if e["kind"] in kinds), None)
    confirmed = plan_end is not None and plan_end + SETTLE_S <= end + 1e-9 and not success
    event: dict[str, Any] | None = None
    if confirmed:
        event = ({"t": found["t"], "kind": found["kind"], "obj": found.get("obj", "")} if found is not None
                 else {"t": plan_end, "kind": "task_failed", "obj": ""})
    return {
        "confirmed": confirmed,
        "event": event,
        "lead_s": None if event is None else round(float(event["t"]) - t_alarm, 3),
        "horizon_s": horizon_s,
        "success_at_end": success,
        "plan_ended": plan_end is not None,
    }


def _forked(env: Any, horizon_s: float, kinds: tuple[str, ...]) -> dict[str, Any] | None:
    """:func:`_continue` in a forked child; None when the child gave no result in time (it is killed)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: a copy of the episode; it must never return into the caller's code
        code = 0
        try:
            os.close(r)
            env.world.events._fh = None  # the ground-truth file belongs to the episode
            env.world.disturbances_paused = True
            data = json.dumps({"ok": _continue(env, horizon_s, kinds)}, default=float).encode()
        except BaseException as exc:  # reported to the parent, which then rolls out in place
            data = json.dumps({"error": f"{type(exc).__name__}: {exc}"}).encode()
            code = 1
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(w, view):]
        finally:
            os._exit(code)
    os.close(w)
    chunks: list[bytes] = []
    deadline = time.monotonic() + FORK_WALL_S
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([r], [], [], left)[0]:
                os.kill(pid, signal.SIGKILL)
                return None
            chunk = os.read(r, 1 << 16)
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(r)
        os.waitpid(pid, 0)
    try:
        reply = json.loads(b"".join(chunks) or b"{}")
    except ValueError:
        return None
    return reply.get("ok")


def _in_place(env: Any, horizon_s: float, kinds: tuple[str, ...]) -> dict[str, Any]:
    """:func:`_continue` on the episode's own world, then its state restored (``isolation="restore"``)."""
    world, policy = env.world, env.policy
    base = _policy_chain(policy)[-1]
    token = world.save_state()
    snap = _snapshot(_stateful(env))
    gen_was_live = getattr(base, "_gen", None) is not None
    action = getattr(base, "action", None)
    fh, world.events._fh = world.events._fh, None  # keep the rollout out of the ground-truth file
    paused, world.disturbances_paused = world.disturbances_paused, True
    try:
        return _continue(env, horizon_s, kinds)
    finally:
        if not gen_was_live and getattr(base, "_gen", None) is not None:
            base._gen.close()
            base._gen = None
        world.restore_state(token)
        _restore(snap)
        if hasattr(base, "action"):
            base.action = action
        world.events._fh = fh
        world.disturbances_paused = paused
