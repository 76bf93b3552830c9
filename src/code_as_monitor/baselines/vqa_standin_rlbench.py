"""``vqa-standin`` rules for the RLBench-style tasks: a stand-in, not a VLM.

Part of :mod:`code_as_monitor.baselines.vqa_standin` (same inputs, same limits): ONE RGB image of the front view,
that view's camera model, the robot's proprioceptive grasp point (its image position, its depth for a
pixels-per-metre scale, its height) and jaw opening. Never depth, segmentation, object poses or history. The
objects are found by colour (the block green, the bulb red on a brass socket, the left lever red and the right one
blue, the stick's shaft wood-brown, the cube blue on a red target, the broom's handle green, the dirt brown in an
orange pan; the drawer's blue front and tray), and every answer is 2-D image geometry:

=============================== ===========================================================================
kind                            answer from the one image
=============================== ===========================================================================
steady, leverstill, otherstill  yes while the item is visible (one image shows no motion); ``steady`` says no
                                when the fingers are down at the table and the item is not between them;
                                ``otherstill`` says no when the other lever looks turned (see ``turned``)
grasped, gripped, levergrip,    the item's blob (its centre; for the stick's shaft and the broom's handle,
bulbgrip                        their axis segment) within ``max_dist`` of the grasp point's image position
lifted                          that, and the grasp point above 5 cm + ``min_rise`` (proprioception)
bulbjaw, jawshut                the jaw opening (proprioception) within [``min_jaw``, ``max_jaw``]
freed, leverfreed               the item farther than ``release_dist`` from the grasp point in the image
carriedin, intray, overtray     the block's centre inside the drawer's blue bounding box (in the gripper for
                                ``carriedin``; only when it is low, by the grasp point's height, for
                                ``overtray``)
bulbseated                      the red ball above the brass socket (horizontal image offset, in socket widths)
screwed                         the white neck between the ball and the socket is hidden: fewer white pixel rows
                                under the ball than 4 mm at the socket's scale (its 4.4 cm width)
levered, turned                 the named lever's blob lies across the image (a closed lever points away from
                                the front camera and looks upright; a turned one lies sideways)
behind                          when the grasp point is low, the shaft's image line passes below the cube (nearer
                                the camera, the cube between it and the target) and the cube is within its ends
ontarget                        the cube's centre inside the red target's bounding box
dragheld                        the stick's shaft at the grasp point (as ``gripped``), or the cube on the target
inpan                           at least ``min_fraction`` of the brown dirt pixels inside the pan's bounding box
=============================== ===========================================================================

A single image's mistakes, on purpose: what lies along the viewing ray is invisible (a block in front of the
drawer can look inside it, a cube behind the target can look on it, dirt behind the pan can look in it), motion is
invisible, a lever turned towards or away from the camera looks closed, and the arm hides what it is over.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.baselines.vqa_pixels import VQAAnswer
from code_as_monitor.baselines.vqa_standin_gripper import Gripper, _mask
from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.observation import View

COLORS: dict[str, tuple[str, ...]] = {"block": ("green",), "bulb": ("red",), "socket": ("brass",),
                                      "left_handle": ("red",), "right_handle": ("blue",), "shaft": ("wood",),
                                      "cube": ("blue",), "target": ("red",), "broom": ("green",),
                                      "drawer": ("blue",), "dirt": ("dirt",), "pan": ("pan",), "neck": ("white",)}
LINES = ("shaft", "broom")
"""Items judged by their axis segment (the gripper holds them off their visible middle)."""
MIN_PIXELS = 8
GRIP_EXTRA = {"shaft": 0.05}
"""Metres between where the gripper holds an item and the nearest visible part of its colour: the stick's black
grip (the table's colour) reaches 5 cm past its shaft's end."""

KEYS = ("steady", "leverstill", "otherstill", "grasped", "gripped", "dragheld", "levergrip", "bulbgrip", "lifted",
        "bulbjaw", "jawshut", "freed", "leverfreed", "carriedin", "intray", "overtray", "bulbseated", "screwed",
        "levered", "turned", "behind", "ontarget", "inpan")


def _item(c: Constraint) -> str | None:
    """Which of this module's items constraint ``c`` is about (a key of :data:`COLORS`), None if not ours."""
    objs = {p.obj: p.part for p in c.parts if p.obj != "robot"}
    if "block" in objs:
        return "block"
    if "lamp" in objs:
        return "bulb"
    if "tap" in objs:
        return next((p for p in objs.values() if p.endswith("_handle")), "left_handle")
    if "stick" in objs and "cube" not in objs:
        return "shaft"
    if "cube" in objs:
        return "cube"
    if "broom" in objs:
        return "broom"
    if "dustpan" in objs:
        return "dirt"
    return None


def _shape(rgb: np.ndarray, item: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | None:
    """(centre (2,), low end (2,), high end (2,), horizontalness |axis_u|) of the item's pixels, or None."""
    vs, us = np.nonzero(_mask(rgb, COLORS[item]))
    if len(us) < MIN_PIXELS:
        return None
    pts = np.stack([us, vs], axis=1).astype(float)
    c = pts.mean(axis=0)
    _, evecs = np.linalg.eigh(np.cov((pts - c).T) + 1e-6 * np.eye(2))
    axis = evecs[:, 1]
    proj = (pts - c) @ axis
    return c, c + axis * float(np.percentile(proj, 98)), c + axis * float(np.percentile(proj, 2)), abs(float(axis[0]))


def _box(rgb: np.ndarray, item: str) -> tuple[float, float, float, float] | None:
    """(left, top, right, bottom) px of the item's pixels, or None."""
    vs, us = np.nonzero(_mask(rgb, COLORS[item]))
    if len(us) < MIN_PIXELS:
        return None
    return float(us.min()), float(vs.min()), float(us.max()), float(vs.max())


def _inside(p: np.ndarray, box: tuple[float, float, float, float] | None) -> bool:
    return box is not None and box[0] <= p[0] <= box[2] and box[1] <= p[1] <= box[3]


def _dist_px(g: Gripper, item: str, s: tuple) -> float:
    """Image distance (px) from the grasp point to the item (its centre, or its axis segment)."""
    if g.uv is None:
        return float("inf")
    p = np.asarray(g.uv, float)
    c, lo, hi, _ = s
    if item in LINES:
        t = float(np.clip(np.dot(p - hi, lo - hi) / max(float(np.dot(lo - hi, lo - hi)), 1e-9), 0.0, 1.0))
        c = hi + t * (lo - hi)
    return float(np.linalg.norm(p - c))


class RLBenchRules:
    """Answers the RLBench-style families' constraints on one front image (see the module docstring)."""

    def answer(self, key: str, c: Constraint, view: View, g: Gripper) -> VQAAnswer | None:
        A = VQAAnswer
        item = _item(c) if key in KEYS else None
        if item is None:
            return None
        th, rgb = c.thresholds, view.rgb
        if key in ("bulbjaw", "jawshut"):
            if g.jaw is None:
                return A(False, "cannot tell whether the gripper's jaws are closed")
            ok = float(th["min_jaw"]) <= g.jaw <= float(th["max_jaw"])
            return A(ok, f"the jaws are {'' if ok else 'not '}closed on it ({g.jaw * 100:.1f} cm apart)")
        s = _shape(rgb, item)
        name = item.replace("_", " ")
        if s is None:
            if key in ("freed", "leverfreed"):
                return A(True, f"the {name} is not visible near the gripper")
            return A(False, f"cannot see the {name} in the image")
        reach = float(th.get("max_dist", 0.04)) + GRIP_EXTRA.get(item, 0.0)
        near = _dist_px(g, item, s) <= reach * g.px_per_m
        turned = s[3] >= 0.7  # the blob lies across the image (within 45 degrees of horizontal)
        if key in ("steady", "leverstill"):
            if key == "steady" and g.uv is not None and g.z <= 0.03 and not near:
                return A(False, f"the fingers are down at the table but the {name} is not between them")
            return A(True, f"the {name} is where the picture shows it (one image shows no motion)")
        if key == "otherstill":  # the constraint's own lever is the other one (the one not to be turned)
            moved = turned
            return A(not moved, f"the other lever {'looks turned' if moved else 'looks closed'}")
        if key == "dragheld":  # the stick held, or the cube (this constraint's item) already on the target
            sh = _shape(rgb, "shaft")
            held = sh is not None and _dist_px(g, "shaft", sh) <= (reach + GRIP_EXTRA["shaft"]) * g.px_per_m
            on = _inside(s[0], _box(rgb, "target"))
            return A(held or on, f"the stick is {'' if held else 'not '}in the gripper and the cube is "
                                 f"{'' if on else 'not '}on the target in the image")
        if key in ("grasped", "gripped", "levergrip", "bulbgrip"):
            return A(near, f"the {name} is {'' if near else 'not '}between the fingers")
        if key == "lifted":
            up = g.z >= 0.05 + float(th.get("min_rise", 0.0))
            return A(near and up, f"the {name} is {'' if near and up else 'not '}lifted in the gripper")
        if key in ("freed", "leverfreed"):
            far = _dist_px(g, item, s) > (float(th.get("release_dist", 0.05)) + GRIP_EXTRA.get(item, 0.0)) * g.px_per_m
            return A(far, f"the {name} is {'released' if far else 'still held'}")
        if key in ("carriedin", "intray", "overtray"):
            inside = _inside(s[0], _box(rgb, "drawer"))
            if key == "carriedin" and near:
                return A(True, "the block is in the gripper")
            if key == "overtray" and g.z - 0.02 >= 0.08 + float(th.get("approach", 0.05)):
                return A(True, "the block is still high above the drawer")
            return A(inside, f"the block is {'' if inside else 'not '}over the drawer's tray in the image")
        if key == "bulbseated":
            sock = _box(rgb, "socket")
            if sock is None:
                return A(True, "the socket is hidden; no sign that the bulb left it")
            w = max(sock[2] - sock[0], 1.0)
            ok = abs(s[0][0] - 0.5 * (sock[0] + sock[2])) <= 0.5 * w
            return A(ok, f"the bulb is {'' if ok else 'not '}on its socket in the image")
        if key == "screwed":
            return self._screwed(rgb, A)
        if key in ("levered", "turned"):
            if key == "levered" and (near or turned):
                return A(True, "the lever is in the gripper or turned")
            state = "lies sideways: turned" if turned else "still points at the tap: closed"
            return A(turned, f"the {name} lever {state}")
        if key == "behind":
            return self._behind(rgb, g, th, s, A)
        if key == "ontarget":
            ok = _inside(s[0], _box(rgb, "target"))
            return A(ok, f"the cube is {'' if ok else 'not '}on the red target in the image")
        if key == "inpan":
            box = _box(rgb, "pan")
            vs, us = np.nonzero(_mask(rgb, COLORS["dirt"]))
            if box is None or len(us) == 0:
                return A(False, "cannot see the dustpan or the dirt")
            frac = float(np.mean((us >= box[0]) & (us <= box[2]) & (vs >= box[1]) & (vs <= box[3])))
            ok = frac >= float(th.get("min_fraction", 0.8))
            return A(ok, f"{frac:.0%} of the dirt is in the dustpan in the image")
        return A(True, f"no visible problem with the {name}")

    @staticmethod
    def _screwed(rgb: np.ndarray, A: type) -> VQAAnswer:
        ball, sock = _box(rgb, "bulb"), _box(rgb, "socket")
        if ball is None or sock is None:
            return A(False, "cannot see the bulb on its socket")
        white = _mask(rgb, COLORS["neck"])
        u0, u1 = int(ball[0]), int(ball[2]) + 1
        rows = white[int(ball[3]):int(sock[1]) + 2, u0:u1].any(axis=1).sum() if sock[1] + 2 > ball[3] else 0
        px_per_m = (sock[2] - sock[0] + 1) / 0.044
        gap = float(rows) / max(px_per_m, 1e-9)
        ok = gap < 0.004
        return A(ok, f"the bulb's neck shows {gap * 1000:.0f} mm above the socket: "
                     f"{'screwed in' if ok else 'not screwed in'}")

    @staticmethod
    def _behind(rgb: np.ndarray, g: Gripper, th: dict, s: tuple, A: type) -> VQAAnswer:
        if g.z >= float(th.get("low", 0.05)) + 0.02:
            return A(True, "the stick is still high")
        shaft, cube = _shape(rgb, "shaft"), _shape(rgb, "cube")
        if shaft is None or cube is None:
            return A(True, "the stick or the cube is hidden; no sign of a miss")
        lo, hi = shaft[1], shaft[2]
        cu = cube[0]
        if not min(lo[0], hi[0]) <= cu[0] <= max(lo[0], hi[0]) or abs(hi[0] - lo[0]) < 1e-6:
            return A(False, "the cube is beside the end of the stick in the image: the stick will miss it")
        v_line = lo[1] + (cu[0] - lo[0]) * (hi[1] - lo[1]) / (hi[0] - lo[0])
        ok = v_line > cu[1]
        return A(ok, f"the stick is {'beyond' if ok else 'in front of'} the cube in the image")


__all__ = ["COLORS", "KEYS", "RLBenchRules"]
