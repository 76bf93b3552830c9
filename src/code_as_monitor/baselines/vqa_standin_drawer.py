"""``vqa-standin`` rules for ``open-drawer`` (drawer cabinet + handle): a stand-in, not a VLM.

Part of :mod:`code_as_monitor.baselines.vqa_standin` (same inputs, same limits): ONE RGB image of the
front view, that view's camera model, and the robot's proprioception: the grasp point (``tip``, world
metres), which gives the gripper's image position and a pixels-per-metre scale at its depth, and the two
fingers (``finger_left``, ``finger_right``), whose distance is the jaw opening. Never depth,
segmentation, object poses or history. The front camera looks at the cabinet over its back, so the
handle bar (8 cm above the table, above the drawer front's top edge) stays in view while the hand
covers it from the top camera; every question is asked on the front view. The picture's parts, by
colour: the cabinet's body (brown), the drawer (blue: its front plate and, once pulled, its tray) and the
handle bar (brass).

- "the handle at the gripper": the handle blob's centre within the constraint's distance of the grasp
  point's image position, the distance converted to pixels at the grasp point's depth;
- "how far is the drawer out": the gap, in the picture, between the body's front top edge (the top of the
  brown blob's outline) and the drawer front's top edge (the top of the blue blob's outline), measured
  across the handle bar and scaled by the bar's apparent length (10 cm, a handle's usual size; read along
  the top of its outline, the top face's far edge). Both edges and (within 1.4 cm) that edge of the bar lie
  at the cabinet's top height, so the picture's points are first laid
  on one horizontal plane by the camera model (the perspective a viewer sees: a gap that runs away from
  the camera looks shorter than a bar across it); lengths on one plane keep their ratios whatever
  plane height is used. The front plate's top is 1.5 cm thick ahead of the body's edge when closed, so
  opening = gap - 1.5 cm. Checked on simulator frames against the joint (10 cabinet poses, and the
  scripted pull with the hand on the bar): within 1 cm up to 17 cm out, within ~6 % farther out (a
  pixel is ~4 mm there);
- "are the jaws closed on it": the jaw opening (proprioception) within the constraint's range, and the
  handle at the gripper in the picture.

Per constraint kind (the id's prefix):

=============== ==========================================================================================
kind             answer from the one image
=============== ==========================================================================================
drawerstill      yes while the handle is visible (one image shows no motion: a drawer pushed 2 cm during the
                 approach looks the same as one left alone)
handlegrip       the handle's centre within ``max_dist`` of the grasp point in the picture
jawshut          the jaw opening in [``min_jaw``, ``max_jaw``] and the handle at the grasp point
handled          the handle at the grasp point, or the drawer already out ``min_open`` (letting go is the
                 plan then); otherwise the grasp slipped
pulled           the drawer out at least ``min_open`` (read as its opening in the picture, not as travel
                 since the pull began: a picture has no "before")
drawerfreed      the handle farther than ``release_dist`` from the grasp point in the picture (or not visible)
=============== ==========================================================================================

The mistakes of one image (and of these rules): an offset along the viewing ray is invisible (a grasp
point 5 cm behind the bar on the camera's line of sight looks "at the handle"); the drawer's motion is
invisible (``drawerstill``); ``pulled`` reads the absolute opening, so after a slip at 4 cm a second pull
of 11 cm reads "out 15 cm" (the kb's travel since the pull began says 11); the scale is the handle bar's
visible length, so fingers hiding one end of the bar make every length look longer (the opening is
overestimated); the bar's top is 1.4 cm below the edges it is compared with, which makes it look ~2.5 %
shorter from this camera (the opening read ~0.4 cm long at 15 cm); a gripper hovering over the bar with
open jaws is "at the handle" in the picture (``jawshut`` tells it from a grasp).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from code_as_monitor.baselines.vqa_pixels import VQAAnswer, color_mask
from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.observation import View

if TYPE_CHECKING:
    from code_as_monitor.baselines.vqa_standin_gripper import Gripper

DRAWER_KEYS = ("drawerstill", "handlegrip", "jawshut", "handled", "pulled", "drawerfreed")
"""Constraint kinds (id prefixes) of the drawer family (``vlm/kb/families/drawer.py``)."""
PART_COLORS: dict[str, str] = {"frame": "brown", "drawer": "blue", "handle": "brass"}
"""Colour (key of ``HSV_RANGES``) of each cabinet part (``sim/assets/drawer_cabinet.urdf``)."""
HANDLE_LENGTH = 0.10
"""Metres: the handle bar's length, the picture's scale for the drawer's opening."""
PLATE_LEAD = 0.015
"""Metres the drawer front's top edge lies ahead of the body's front edge when closed (the plate's thickness)."""
GRIP_DIST = 0.03
"""Metres: "the handle at the gripper" when a constraint gives no ``max_dist`` (``jawshut``): the grasp
check's tolerance (``drawer_handle_grip``)."""
MIN_PIXELS = 12
"""Fewer brass pixels than this and the handle counts as not visible (the bar alone is ~60-130 px)."""
FRAME_EDGE_PCT = 90.0
"""Percentile (along the drawer's axis) of the brown outline's top points taken as the body's front edge:
the top of the outline is that edge plus the top face's side edges, which lie nearer the camera."""
PLATE_EDGE_PCT = 75.0
"""Percentile of the blue outline's top points taken as the drawer front's top edge: below the handle's
posts (8 mm wide, 3 cm beyond it), above columns where the fingers hide the edge."""


@dataclass(frozen=True)
class Cabinet:
    """The cabinet as one picture shows it: the handle blob's centre (u, v) px (None when not visible),
    and the drawer's opening (metres, None when the body or the drawer front cannot be measured)."""

    handle_uv: np.ndarray | None
    opening: float | None


def is_drawer_constraint(key: str, c: Constraint) -> bool:
    """True for the drawer family's constraints (a kind of :data:`DRAWER_KEYS` about a cabinet/drawer)."""
    if key not in DRAWER_KEYS:
        return False
    names = [p.obj for p in c.parts] + [c.id.split("_", 1)[-1]]
    return any("drawer" in n or "cabinet" in n for n in names)


def _mask(rgb: np.ndarray, color: str, min_area: int = 3) -> np.ndarray:
    """(H, W) bool: pixels of ``color`` without speckle (connected pieces under ``min_area`` pixels)."""
    import cv2

    m = color_mask(rgb, color)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(m.astype(np.uint8), connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area
    keep[0] = False
    return keep[labels]


def on_plane(view: View, uv: np.ndarray) -> np.ndarray:
    """(N, 2) world x, y (metres, up to one common scale) where the rays through pixels ``uv`` (N, 2) meet
    the table plane z = 0: points that share a height keep their length ratios on it."""
    cam = view.camera
    uv = np.asarray(uv, float).reshape(-1, 2)
    rays = cam.T_world_cam[:3, :3] @ (np.linalg.inv(cam.K) @ np.vstack([uv.T, np.ones(len(uv))]))
    c = cam.T_world_cam[:3, 3]
    t = -c[2] / np.where(np.abs(rays[2]) > 1e-9, rays[2], -1e-9)
    return (c[:, None] + rays * t)[:2].T


def _top_outline(m: np.ndarray) -> np.ndarray:
    """(N, 2) (u, v) px: the topmost pixel of the mask in each image column that has one."""
    cols = np.nonzero(m.any(axis=0))[0]
    return np.stack([cols, m[:, cols].argmax(axis=0)], axis=1).astype(float)


def _bar_length(view: View, top: np.ndarray, centre: np.ndarray, along: np.ndarray) -> float:
    """The bar's length on the plane of :func:`on_plane` (same scale), from the top of its outline (``top``,
    (N, 2) px): that is its top face's far edge, at one height. All of its pixels would not do: its side
    faces below that edge, laid on the plane as if at the edge's height, stretch it along the viewing
    direction, which runs partly along a turned bar (+1 cm for a bar turned 25 degrees from square on).
    Plus one pixel: the end pixels' centres lie half a pixel inside the bar's ends."""
    proj = (on_plane(view, top) - centre) @ along
    i, j = int(np.argmin(proj)), int(np.argmax(proj))
    step = np.array([[0.5, 0.0], [-0.5, 0.0]]) if top[j, 0] >= top[i, 0] else np.array([[-0.5, 0.0], [0.5, 0.0]])
    ends = (on_plane(view, np.stack([top[j] + step[0], top[i] + step[1]])) - centre) @ along
    return float(ends[0] - ends[1])


def look(view: View) -> Cabinet:
    """The handle's image centre and the drawer's opening read off the view's RGB (see the module docstring)."""
    vs, us = np.nonzero(_mask(view.rgb, PART_COLORS["handle"]))
    if len(us) < MIN_PIXELS:
        return Cabinet(None, None)
    handle_uv = np.array([us.mean(), vs.mean()])
    bar = on_plane(view, np.stack([us, vs], axis=1))
    centre = bar.mean(axis=0)
    _, evecs = np.linalg.eigh(np.cov((bar - centre).T) + 1e-12 * np.eye(2))
    along = evecs[:, 1]
    length = _bar_length(view, _top_outline(_mask(view.rgb, PART_COLORS["handle"])), centre, along)
    body = _mask(view.rgb, PART_COLORS["frame"], 20)
    front = _mask(view.rgb, PART_COLORS["drawer"], 5)
    if length <= 1e-6 or not body.any() or not front.any():
        return Cabinet(handle_uv, None)
    axis = np.array([-along[1], along[0]])  # the drawer's axis: across the bar, away from the camera
    if float(np.dot(centre - view.camera.position[:2], axis)) < 0:
        axis = -axis
    body_edge = float(np.percentile(on_plane(view, _top_outline(body)) @ axis, FRAME_EDGE_PCT))
    plate_edge = float(np.percentile(on_plane(view, _top_outline(front)) @ axis, PLATE_EDGE_PCT))
    return Cabinet(handle_uv, (plate_edge - body_edge) * HANDLE_LENGTH / length - PLATE_LEAD)


def _dist_m(cab: Cabinet, g: Gripper) -> float | None:
    """Image distance (metres at the grasp point's depth) from the grasp point to the handle's centre."""
    if cab.handle_uv is None or g.uv is None or g.px_per_m <= 0:
        return None
    return float(np.linalg.norm(np.asarray(g.uv, float) - cab.handle_uv)) / g.px_per_m


class DrawerRules:
    """Answers the drawer family's constraints on one front image (see the module docstring)."""

    def answer(self, key: str, c: Constraint, view: View, g: Gripper) -> VQAAnswer | None:
        """Yes/no for constraint ``c`` (kind ``key``), or None when it is not a drawer constraint."""
        A = VQAAnswer

        if not is_drawer_constraint(key, c):
            return None
        th = c.thresholds
        cab = look(view)
        if cab.handle_uv is None:
            if key == "drawerfreed":
                return A(True, "the handle is not visible near the gripper")
            return A(False, "cannot see the drawer's handle in the image")
        d = _dist_m(cab, g)
        at = d is not None and d <= float(th.get("max_dist", GRIP_DIST))
        far = "" if d is None else f" ({d * 100:.0f} cm from it in the image)"
        out = cab.opening
        out_s = ("cannot tell how far the drawer is out" if out is None
                 else f"the drawer is out about {max(out, 0.0) * 100:.0f} cm")
        if key == "drawerstill":
            return A(True, "the handle is where the picture shows it (one image shows no motion)")
        if key == "handlegrip":
            return (A(True, "the handle is between the fingers") if at
                    else A(False, f"the handle is not between the fingers{far}"))
        if key == "jawshut":
            if g.jaw is None:
                return A(False, "cannot tell whether the gripper's jaws are closed")
            shut = float(th.get("min_jaw", 0.01)) <= g.jaw <= float(th.get("max_jaw", 0.05))
            if shut and at:
                return A(True, f"the jaws are closed on the handle ({g.jaw * 100:.1f} cm apart)")
            if not shut:
                return A(False, f"the jaws are not closed on the handle ({g.jaw * 100:.1f} cm apart)")
            return A(False, f"the jaws are closed but not on the handle{far}")
        min_open = float(th.get("min_open", 0.15))
        opened = out is not None and out >= min_open
        if key == "handled":
            if at:
                return A(True, f"the handle is in the gripper; {out_s}")
            if opened:
                return A(True, f"{out_s}: far enough, letting go of the handle is fine")
            return A(False, f"the grasp slipped: the handle is not in the gripper{far} and {out_s}, "
                            f"less than {min_open * 100:.0f} cm")
        if key == "pulled":
            return (A(True, f"{out_s} (at least {min_open * 100:.0f} cm)") if opened
                    else A(False, f"{out_s}, not {min_open * 100:.0f} cm"))
        if key == "drawerfreed":
            rel = d is None or d > float(th.get("release_dist", 0.06))
            return (A(True, f"the handle is released: the gripper is away from it{far}") if rel
                    else A(False, f"the gripper still holds the handle{far}"))
        return A(True, "no visible problem with the drawer")


__all__ = ["DRAWER_KEYS", "PART_COLORS", "Cabinet", "DrawerRules", "is_drawer_constraint", "look", "on_plane"]
