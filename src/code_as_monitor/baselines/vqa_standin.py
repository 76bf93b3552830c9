"""``vqa-standin``: a rule-based, single-image yes/no answerer standing in for a VQA model.

**This is a stand-in, not a VLM.** Offline, the DoReMi-style and Inner-Monologue-style baselines need
something that answers "is this constraint satisfied?" the way a VQA model does: from ONE current RGB
image, with no depth, no segmentation masks, no object poses and no history. This module answers by
colour segmentation (HSV thresholds on the RGB of one view) and 2-D image-plane heuristics:

- stacking (front view): is the green blob sitting on top of the red blob in the image? are their
  horizontal image centres close? is the blob near the suction tip's image position? (Whether another
  block hangs under the cup instead, ``taken``, is not judged: one image cannot tell which of two blocks
  along the line of sight is on the cup; the answer is yes.)
- sweeping (top view): how many block-coloured pixels, in units of one block's apparent area, lie
  inside the yellow zone's image rectangle?
- rope (top view): along the side of the square's outline that has no outline pixels (the opening),
  is there rope-coloured pixel near every sample point?
- pen + holder and book + shelf (front view; rules in
  :mod:`~code_as_monitor.baselines.vqa_standin_gripper`): is the item's image centre at the gripper's
  image position (held, gripped, released)? is its blob's long axis along the image direction of
  vertical (upright, standing)? is its lower end above the opening when low, or down inside the rim's
  image box (over, aimed, inside, shelved)?
- drawer cabinet (front view; rules in :mod:`~code_as_monitor.baselines.vqa_standin_drawer`): is the
  handle bar's blob at the gripper's image position (gripped, handled, released)? are the jaws closed
  on it (jaw opening from proprioception)? how far is the drawer out: the gap between the cabinet's and
  the drawer front's top edges, in handle-bar lengths (pulled)? The drawer's motion is not in one image
  (``drawerstill`` is yes while the handle is visible).
- teapot + teacup (front view; rules in :mod:`~code_as_monitor.baselines.vqa_standin_tea`): is the
  handle fin's blob at the gripper's image position (grasped, lifted, gripped, freed)? is the lid level
  (its pixels, laid on a horizontal plane, as round as a level square's: potlevel)? is the lid's long
  image axis tilted past the pour angle with the spout below the handle (pourtilt, draintilt)? is the
  spout blob above the cup blob (spoutover)?
- the RLBench-style tasks (front view; rules in :mod:`~code_as_monitor.baselines.vqa_standin_rlbench`):
  the block in the drawer's blue box, the bulb's white neck hidden under the red ball, a lever's blob lying
  sideways (turned), the cube inside the red target's box, the brown dirt pixels in the orange pan's box.

Inputs it may use: ``view.rgb`` and ``view.camera`` (intrinsics/extrinsics of the chosen view) and
the robot's proprioceptive tip position (``obs.robot.ee_points["tip"]``), projected into the image
as a proxy for "where the gripper is in the picture", and the gripper's jaw opening (the distance of
``finger_left`` and ``finger_right``, proprioception). It never reads ``depth``, ``seg`` or
``obs.object_poses``. So it makes a single image's mistakes: a block lying on the table behind the
tower looks "on top" in the front view, an offset along the viewing ray is invisible, the arm
occludes blocks, touching blocks merge into one blob; a tilt or an offset towards the camera is
invisible, and an item lying behind a raised gripper looks held; a grasp point behind the drawer's
handle on the line of sight looks at it, and a drawer that moved looks still; a spout behind the cup
on the line of sight looks over it, and a pot pouring towards the camera does not look tipped.
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.baselines.vqa_pixels import HSV_RANGES, Blob, VQAAnswer, blobs, color_mask
from code_as_monitor.baselines.vqa_standin_drawer import DrawerRules
from code_as_monitor.baselines.vqa_standin_gripper import Gripper, GripperRules
from code_as_monitor.baselines.vqa_standin_rlbench import RLBenchRules
from code_as_monitor.baselines.vqa_standin_tea import TeaRules
from code_as_monitor.baselines.vqa_views import question_view
from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.observation import Observation, View

NAME = "vqa-standin"
DESCRIPTION = "vqa-standin: a rule-based single-image VQA stand-in (not a VLM)"

NEAR_TIP_FRAC = (0.5, 0.6)
"""A blob counts as "on the suction cup" when its centre is within (0.5 blob widths sideways, 0 to 0.6
blob widths below) the tip's image position."""


def _block_color(obj: str) -> str | None:
    for c in ("red", "green", "blue"):
        if obj.startswith(c + "_"):
            return c
    return None


def _nice(obj: str) -> str:
    return obj.replace("_", " ")


class VQAStandin:
    """Answers a constraint about one image (see the module docstring). Stateless."""

    name = NAME

    def __init__(self) -> None:
        self._tip_z = 0.0

    @staticmethod
    def view_for(constraint: Constraint) -> str:
        """The one view a question is asked on: top-down for counting and rope, front for stacking and for
        the gripper tasks (the top view sees the held pen or book only past the arm and hand above it, and
        not the drawer's handle under the hand: the front camera sees the bar over the cabinet)."""
        objs = {p.obj for p in constraint.parts}
        return "top" if objs & {"zone", "rope", "square"} else "front"

    def answer(self, constraint: Constraint, obs: Observation) -> VQAAnswer:
        """Yes/no for ``constraint`` on the single view :meth:`view_for` wants (or the most similar one the
        observation has: :func:`~code_as_monitor.baselines.vqa_views.question_view`)."""
        view = obs.views[question_view(self.view_for(constraint), obs)]
        key = constraint.id.split("_", 1)[0]
        objs = [p.obj for p in constraint.parts if p.obj != "robot"]
        tip_uv, grip = None, Gripper(None, 0.0, 0.0)
        tip = obs.robot.ee_points.get("tip") if obs.robot is not None else None
        self._tip_z = float(tip[2]) if tip is not None else 0.0
        if tip is not None:
            uv, z = view.camera.project(np.asarray(tip, dtype=float)[None])
            tip_uv = uv[0] if z[0] > 0 else None
            # pixels per metre at the gripper's depth (its own position: proprioception, not scene depth);
            # the jaw opening: the fingers' distance (proprioception), when the gripper reports its fingers
            fl = obs.robot.ee_points.get("finger_left") if obs.robot is not None else None
            fr = obs.robot.ee_points.get("finger_right") if obs.robot is not None else None
            jaw = None if fl is None or fr is None else float(np.linalg.norm(np.asarray(fl) - np.asarray(fr)))
            grip = Gripper(tip_uv, float(view.camera.K[1, 1]) / max(float(z[0]), 1e-6), self._tip_z, jaw)
        got = DrawerRules().answer(key, constraint, view, grip)
        if got is None:
            got = RLBenchRules().answer(key, constraint, view, grip)
        if got is None:
            got = TeaRules().answer(key, constraint, view, grip)
        if got is None:
            got = GripperRules().answer(key, constraint, view, grip)
        if got is not None:
            return got
        if key in ("reached", "capped"):
            return self._count(constraint, view, key)
        if key == "rope":
            return self._rope(view)
        return self._stack(key, objs, view, tip_uv, constraint)

    # --- stacking (front view) -----------------------------------------------------------------------
    def _find(self, view: View, obj: str) -> Blob | None:
        color = _block_color(obj)
        if color is None:
            return None
        found = blobs(color_mask(view.rgb, color))
        return found[0] if found else None

    @staticmethod
    def _near_tip(b: Blob, tip_uv: np.ndarray | None) -> bool:
        """The blob hangs just under the tip in the image (within half a blob sideways, 0..0.6 blob down)."""
        if tip_uv is None:
            return False
        du, dv = b.u - tip_uv[0], b.v - tip_uv[1]
        return abs(du) <= NEAR_TIP_FRAC[0] * b.width and -2.0 <= dv <= NEAR_TIP_FRAC[1] * b.width

    @staticmethod
    def _on(upper: Blob, lower: Blob) -> bool:
        """2-D "on top of": horizontal overlap and the upper blob's bottom at the lower blob's top edge."""
        overlap = min(upper.right, lower.right) - max(upper.left, lower.left) + 1
        if overlap < 0.3 * min(upper.width, lower.width):
            return False
        return lower.top - 4 <= upper.bottom <= lower.top + 0.6 * (lower.bottom - lower.top + 1)

    def _stack(self, key: str, objs: list[str], view: View, tip_uv: np.ndarray | None,
               c: Constraint) -> VQAAnswer:
        if not objs:
            return VQAAnswer(True, "nothing to check in the image")
        x = objs[0]
        bx = self._find(view, x)
        target = objs[1] if len(objs) > 1 else None
        bt = self._find(view, target) if target else None
        if key == "taken":  # which of two blocks hangs under the cup needs depth: not judged from one image
            return VQAAnswer(True, f"no other block is seen on the suction cup instead of {_nice(x)}")
        if key == "tower" and (bx is None or bt is None):  # one of the two hidden (the arm): no sign of a collapse
            return VQAAnswer(True, f"{_nice(x)} and {_nice(target or '')} are not both visible; no sign of a collapse")
        if key == "still":
            if bx is None:
                return VQAAnswer(False, f"cannot see {_nice(x)} in the image; it may have been moved")
            return VQAAnswer(True, f"{_nice(x)} is visible (one image shows no motion)")
        if bx is None:
            if key == "released":
                return VQAAnswer(True, f"{_nice(x)} is not visible near the suction cup")
            return VQAAnswer(False, f"cannot see {_nice(x)}; it is not held or was dropped")
        near = self._near_tip(bx, tip_uv)
        if key == "held":
            lifted = self._tip_z >= float(c.thresholds.get("min_z", 0.05)) + 0.02  # proprioception
            return (VQAAnswer(True, f"{_nice(x)} is held by the suction cup") if near and lifted
                    else VQAAnswer(False, f"{_nice(x)} is not held by the suction cup"))
        if key == "released":
            return (VQAAnswer(False, f"{_nice(x)} is still held by the suction cup") if near
                    else VQAAnswer(True, f"{_nice(x)} is released"))
        if bt is None:
            return VQAAnswer(False, f"cannot see {_nice(target or '')}; {_nice(x)} is not resting on it")
        on = self._on(bx, bt)
        if key == "attached":
            ok = near or on
            return (VQAAnswer(True, f"{_nice(x)} is on the suction cup or on {_nice(target or '')}") if ok
                    else VQAAnswer(False, f"{_nice(x)} dropped: not attached to the suction cup"))
        if key == "resting":
            return (VQAAnswer(True, f"{_nice(x)} rests on {_nice(target or '')}") if on
                    else VQAAnswer(False, f"{_nice(x)} is not resting on {_nice(target or '')}"))
        if key == "tower":
            return (VQAAnswer(True, f"{_nice(x)} is on {_nice(target or '')}") if on
                    else VQAAnswer(False, f"{_nice(x)} is no longer on {_nice(target or '')}; the tower collapsed"))
        if key == "centred":
            tol_m = float(c.thresholds.get("max_offset", 0.015))
            tol_px = tol_m / 0.04 * max(bt.width, 1)
            du = abs(bx.u - bt.u)
            if on and du <= tol_px:
                return VQAAnswer(True, f"{_nice(x)} looks centred on {_nice(target or '')}")
            return VQAAnswer(False, f"{_nice(x)} looks offset from the centre of {_nice(target or '')}")
        return VQAAnswer(True, f"no visible problem with {_nice(x)}")

    # --- sweeping (top view) --------------------------------------------------------------------------
    def count_in_zone(self, view: View) -> int:
        """Estimated number of blocks inside the zone's image rectangle (area / one block's area)."""
        zone = blobs(color_mask(view.rgb, "yellow"), min_area=20)
        if not zone:
            return 0
        z = zone[0]
        brick = color_mask(view.rgb, "brick")
        singles = [b.area for b in blobs(brick, min_area=3)]
        unit = float(np.percentile(singles, 25)) if singles else 1.0
        inside = brick[z.top:z.bottom + 1, z.left:z.right + 1].sum()
        return round(float(inside) / max(unit, 1.0))

    def _count(self, c: Constraint, view: View, key: str) -> VQAAnswer:
        n = self.count_in_zone(view)
        if key == "reached":
            want = int(c.thresholds.get("target", 0))
            return (VQAAnswer(True, f"about {n} blocks are inside the zone (at least {want})") if n >= want
                    else VQAAnswer(False, f"only about {n} blocks are inside the zone, fewer than {want}"))
        upper = int(c.thresholds.get("upper", 1 << 30))
        return (VQAAnswer(True, f"about {n} blocks are inside the zone") if n <= upper
                else VQAAnswer(False, f"about {n} blocks are inside the zone, more than {upper}"))

    # --- rope (top view) --------------------------------------------------------------------------------
    def rope_coverage(self, view: View) -> float:
        """Fraction of sample points along the outline's open side with rope pixels nearby."""
        import cv2

        hsv = cv2.cvtColor(np.ascontiguousarray(view.rgb), cv2.COLOR_RGB2HSV)
        white = ((hsv[..., 1] < 50) & (hsv[..., 2] > 150)).astype(np.uint8)
        opened = cv2.morphologyEx(white, cv2.MORPH_OPEN, np.ones((5, 5), np.uint8))
        thick = cv2.dilate(opened, np.ones((7, 7), np.uint8))  # the arm; the outline is thin
        thin = (white > 0) & (thick == 0)
        comps = blobs(thin, min_area=15)
        if not comps:
            return 0.0
        o = comps[0]
        rope = color_mask(view.rgb, "orange")
        sides = {
            "left": ((o.left, o.top), (o.left, o.bottom)), "right": ((o.right, o.top), (o.right, o.bottom)),
            "top": ((o.left, o.top), (o.right, o.top)), "bottom": ((o.left, o.bottom), (o.right, o.bottom)),
        }

        def density(mask: np.ndarray, a: tuple[int, int], b: tuple[int, int], r: int) -> list[bool]:
            hits = []
            for s in np.linspace(0.1, 0.9, 12):
                u, v = int(a[0] + s * (b[0] - a[0])), int(a[1] + s * (b[1] - a[1]))
                hits.append(bool(mask[max(v - r, 0):v + r + 1, max(u - r, 0):u + r + 1].any()))
            return hits

        open_side = min(sides, key=lambda k: sum(density(thin, *sides[k], 2)))
        return float(np.mean(density(rope, *sides[open_side], 4)))

    def _rope(self, view: View) -> VQAAnswer:
        cov = self.rope_coverage(view)
        if cov >= 0.9:
            return VQAAnswer(True, f"the rope lies along the opening ({cov:.0%} of it)")
        return VQAAnswer(False, f"the opening is not enclosed yet (rope along {cov:.0%} of it)")


__all__ = ["DESCRIPTION", "HSV_RANGES", "NAME", "Blob", "VQAAnswer", "VQAStandin", "blobs", "color_mask"]
