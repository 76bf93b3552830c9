"""``vqa-standin`` rules for ``pour-tea`` (teapot + teacup): a stand-in, not a VLM.

Part of :mod:`code_as_monitor.baselines.vqa_standin` (same inputs, same limits): ONE RGB image of the
front view, that view's camera model, and the robot's proprioceptive grasp point (``tip``, world metres:
the gripper's image position, a pixels-per-metre scale at its depth, its height above the table). Never
depth, segmentation, object poses or history. The picture's parts, by colour: the pot's lid (red, a flat
square slab), its spout trough (blue), its handle fin (dark brown; the tea is a more saturated brown),
and the cup (green body, gold rim). Every question is asked on the front view, which sees the pot's tilt
towards the cup across the picture (the top view sees the hand above the pot).

- "the pot in the gripper": the handle blob's centre within the constraint's distance of the grasp
  point's image position (distance converted to pixels at the grasp point's depth);
- "level": a level lid is a horizontal square, and a square's pixel spread is the same in every
  direction on its own plane; the lid's pixels are laid on a horizontal plane by the camera model (as a
  viewer undoes perspective) and the spread's elongation (long/short, square root of the eigenvalue
  ratio) is compared with the least elongation a lid tilted by ``max_tilt`` would show from this camera,
  over every tilt direction (worked out from the camera ray at the lid; a geometric bound, not a fit);
- "tipped spout-down by at least X": the lid's long axis in the picture at least X from the picture's
  horizontal there (a lid turned about the line of sight turns by its tilt in the picture), and the
  spout lower in the picture than the handle;
- "the spout over the cup": the spout blob's centre within ``max_offset`` of the cup's centre across the
  picture (at the grasp point's scale) and not below the cup's bottom edge.

Per constraint kind (the id's prefix): ``grasped`` (handle at the grasp point, ``max_dist``), ``lifted``
(grasped and the grasp point above ``min_z``, proprioception), ``gripped`` (handle at the grasp point),
``freed`` (handle farther than ``release_dist``, or not visible), ``potlevel`` (level as above),
``pourtilt`` and ``draintilt`` (tipped spout-down by ``min_tilt``), ``spoutover`` (as above).

The mistakes of one image (and of these rules): an offset along the viewing ray is invisible (a spout
8 cm behind the cup on the line of sight looks "over" it); a tilt partly along the line of sight turns
the lid less in the picture, so a pot tipped 41 degrees towards the cup's side reads as ~37 (the drain's
40 is missed); the level bound is the 15-degree tilt's least elongation, and pixels (a lid ~30 px wide)
or the fingers hiding a corner move a lid tilted near 15 degrees to either side of it (one tipped 11
degrees forward read "not level" on a simulator frame); "spout-down" is the spout's blob centre lower in
the picture than the handle's, which a pot seen from the spout's end can get wrong.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from code_as_monitor.baselines.vqa_pixels import VQAAnswer
from code_as_monitor.baselines.vqa_standin_drawer import _mask, on_plane
from code_as_monitor.baselines.vqa_standin_gripper import Gripper, image_down
from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.observation import View

TEA_KEYS = ("grasped", "lifted", "gripped", "freed", "potlevel", "pourtilt", "draintilt", "spoutover")
"""Constraint kinds (id prefixes) of the tea family (``vlm/kb/families/tea.py``)."""
PART_COLORS: dict[str, str] = {"lid": "red", "spout": "blue", "handle": "pothandle", "cup": "green"}
"""Colour (key of ``HSV_RANGES``) of each part (``sim/assets/teapot.urdf``, ``teacup.urdf``)."""
MIN_PIXELS = 12
"""Fewer pixels than this and a part counts as not visible (the lid edge-on is ~70 px, the handle ~60+)."""
MIN_AXIS_ELONGATION = 1.25
"""The lid's blob has a readable long axis in the picture when it is at least 1.25 x as long as wide (a level
lid from the front camera is ~1.5:1, edge-on ~5:1 or more)."""


@dataclass(frozen=True)
class Blob2:
    """A part's pixels: centre (u, v) px, bounding box (left, top, right, bottom) px, pixel count."""

    uv: np.ndarray
    box: tuple[int, int, int, int]
    area: int


def is_tea_constraint(key: str, c: Constraint) -> bool:
    """True for the tea family's constraints (a kind of :data:`TEA_KEYS` about a teapot or teacup)."""
    if key not in TEA_KEYS:
        return False
    return any("teapot" in p.obj or "teacup" in p.obj for p in c.parts)


def _blob(rgb: np.ndarray, part: str) -> Blob2 | None:
    vs, us = np.nonzero(_mask(rgb, PART_COLORS[part]))
    if len(us) < MIN_PIXELS:
        return None
    return Blob2(np.array([us.mean(), vs.mean()]), (int(us.min()), int(vs.min()), int(us.max()), int(vs.max())),
                 len(us))


def _ray(view: View, uv: np.ndarray) -> np.ndarray:
    """(3,) unit world direction of the camera ray through pixel ``uv``."""
    cam = view.camera
    d = cam.T_world_cam[:3, :3] @ (np.linalg.inv(cam.K) @ np.array([uv[0], uv[1], 1.0]))
    return d / np.linalg.norm(d)


def _elongation(M: np.ndarray) -> float:
    ev = np.linalg.eigvalsh(M)
    return float(np.sqrt(ev[1] / max(ev[0], 1e-12)))


def tilted_square_elongation(ray: np.ndarray, tilt: float) -> float:
    """The least elongation (over tilt directions) of a square tilted by ``tilt`` (radians) from horizontal,
    laid back on a horizontal plane along ``ray`` (the camera ray at it, world frame). A level square gives 1."""
    out = np.inf
    for phi in np.linspace(0.0, np.pi, 37):
        a = np.array([np.cos(phi), np.sin(phi), 0.0])
        K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
        R = np.eye(3) + np.sin(tilt) * K + (1 - np.cos(tilt)) * K @ K
        cols = [(R @ e)[:2] - (R @ e)[2] * ray[:2] / ray[2] for e in (np.eye(3)[0], np.eye(3)[1])]
        M = np.stack(cols, axis=1)
        out = min(out, _elongation(M @ M.T))
    return float(out)


@dataclass(frozen=True)
class Lid:
    """The lid in one picture: centre (u, v) px, its spread's elongation laid on a horizontal plane, its long
    axis's angle (degrees) from the picture's horizontal there, and its elongation in the picture."""

    uv: np.ndarray
    plane_elongation: float
    image_angle: float
    image_elongation: float


def lid_of(view: View) -> Lid | None:
    """The lid's :class:`Lid` from its red pixels, or None when fewer than :data:`MIN_PIXELS` show."""
    vs, us = np.nonzero(_mask(view.rgb, PART_COLORS["lid"]))
    if len(us) < MIN_PIXELS:
        return None
    px = np.stack([us, vs], axis=1).astype(float)
    c = px.mean(axis=0)
    P = on_plane(view, px)
    plane_el = _elongation(np.cov((P - P.mean(axis=0)).T))
    cov = np.cov((px - c).T) + 1e-6 * np.eye(2)
    ev, evecs = np.linalg.eigh(cov)
    down = image_down(view, (float(c[0]), float(c[1])))
    horizontal = np.array([-down[1], down[0]])
    ang = float(np.degrees(np.arccos(min(1.0, abs(float(np.dot(evecs[:, 1], horizontal)))))))
    return Lid(c, plane_el, ang, float(np.sqrt(ev[1] / max(ev[0], 1e-12))))


def _near(b: Blob2 | None, g: Gripper, dist_m: float) -> tuple[bool, str]:
    if b is None or g.uv is None or g.px_per_m <= 0:
        return False, ""
    d = float(np.linalg.norm(np.asarray(g.uv, float) - b.uv)) / g.px_per_m
    return d <= dist_m, f" ({d * 100:.0f} cm from the grasp point in the image)"


class TeaRules:
    """Answers the tea family's constraints on one front image (see the module docstring)."""

    def answer(self, key: str, c: Constraint, view: View, g: Gripper) -> VQAAnswer | None:
        """Yes/no for constraint ``c`` (kind ``key``), or None when it is not a tea constraint."""
        A = VQAAnswer

        if not is_tea_constraint(key, c):
            return None
        th = c.thresholds
        if key in ("grasped", "lifted", "gripped", "freed"):
            handle = _blob(view.rgb, "handle")
            if handle is None:
                return (A(True, "the teapot's handle is not visible near the gripper") if key == "freed"
                        else A(False, "cannot see the teapot's handle in the image"))
            if key == "freed":
                held, far = _near(handle, g, float(th.get("release_dist", 0.06)))
                return (A(False, f"the gripper still holds the teapot's handle{far}") if held
                        else A(True, f"the teapot is let go{far}"))
            held, far = _near(handle, g, float(th.get("max_dist", 0.04)))
            if key == "lifted":
                up = g.z >= float(th.get("min_z", 0.10))
                return (A(True, "the teapot is lifted in the gripper") if held and up
                        else A(False, f"the teapot is not lifted: not in the gripper{far} or still low"))
            return (A(True, f"the teapot's handle is in the gripper{far}") if held
                    else A(False, f"the teapot's handle is not in the gripper{far}: it dropped or slipped"))
        if key == "spoutover":
            spout, cup = _blob(view.rgb, "spout"), _blob(view.rgb, "cup")
            if spout is None or cup is None:
                return A(False, "cannot see the spout or the cup in the image")
            off = abs(float(spout.uv[0] - cup.uv[0])) / max(g.px_per_m, 1e-9) if g.px_per_m > 0 else np.inf
            above = spout.uv[1] <= cup.box[3]
            if above and off <= float(th.get("max_offset", 0.08)):
                return A(True, f"the spout is above the cup ({off * 100:.0f} cm to the side in the image)")
            return A(False, f"the spout is not above the cup ({off * 100:.0f} cm to the side in the image)")
        lid = lid_of(view)
        if lid is None:
            return A(False, "cannot see the teapot's lid in the image")
        if key == "potlevel":
            max_tilt = float(th.get("max_tilt", np.radians(15.0)))
            bound = tilted_square_elongation(_ray(view, lid.uv), max_tilt)
            if lid.plane_elongation < bound:
                return A(True, "the teapot looks level (its lid looks flat)")
            return A(False, f"the teapot is not level: its lid looks tilted more than "
                            f"{np.degrees(max_tilt):.0f} degrees")
        # pourtilt, draintilt: tipped spout-down by min_tilt
        min_tilt = float(np.degrees(float(th.get("min_tilt", np.radians(50.0)))))
        spout, handle = _blob(view.rgb, "spout"), _blob(view.rgb, "handle")
        down = spout is not None and handle is not None and spout.uv[1] > handle.uv[1]
        if lid.image_elongation >= MIN_AXIS_ELONGATION and lid.image_angle >= min_tilt and down:
            return A(True, f"the teapot is tipped spout-down (its lid {lid.image_angle:.0f} degrees from "
                           f"horizontal in the image)")
        return A(False, f"the teapot is not tipped {min_tilt:.0f} degrees spout-down (its lid "
                        f"{lid.image_angle:.0f} degrees from horizontal in the image)")


__all__ = ["PART_COLORS", "TEA_KEYS", "Lid", "TeaRules", "is_tea_constraint", "lid_of", "tilted_square_elongation"]
