"""``vqa-standin`` rules for the gripper tasks (pen + holder, book + shelf): a stand-in, not a VLM.

Part of :mod:`code_as_monitor.baselines.vqa_standin` (same inputs, same limits): ONE RGB image of the
front view, that view's camera model, and the robot's proprioceptive grasp point (``tip``, world
metres), which gives the gripper's image position, its depth from the camera (for a pixels-per-metre
scale at the gripper) and its height above the table. Never depth, segmentation, object poses or
history. Every answer comes from colour blobs and 2-D image-plane geometry:

- the item's pixels (pen: blue body + yellow tip; book: red cover + cream spine) give a centre, a
  principal axis (PCA of the pixel coordinates), how elongated it is, and its lower end in the image;
- "in the gripper": the item (its image centre, or its axis segment when the constraint's element of
  it is a LINE, as the pen's is) within the constraint's distance of the grasp point's image position,
  the distance converted to pixels at the grasp point's depth;
- "upright": the principal axis within the constraint's angle of the image direction of world
  vertical at that spot (the vertical vanishing point of the camera: a VQA model knows which way is up
  in a picture); a blob too round to have an axis is "not clearly upright";
- "above / inside the opening": the item's lower end against the bounding box of the container's rim
  colour (holder: orange rim on a green body; shelf: teal rim on a wood body).

Per constraint kind (the id's prefix; the pen's and the book's families share names):

=================== ==================================================================================
kind                 answer from the one image
=================== ==================================================================================
steady, aligned      yes while the item is visible (one image shows no motion); ``steady`` also says no
                     when the fingers are down at the table (grasp point height) and the item is not
                     between them
grasped              the item (centre or axis) at the grasp point (``max_dist``)
lifted, raised       grasped, and the grasp point above ``min_z`` (proprioception); ``raised`` (the book rose
                     ``min_rise`` since the grasp began) needs a history: read as lifted, above 5 cm + ``min_rise``
gripped              the item (centre or axis) at the grasp point (``max_dist``)
carried, conveyed    at the grasp point, or its lower end already inside the container's opening
upright, standing    axis within ``max_tilt`` of image vertical, blob elongated
poised               when held: as ``upright``; not held: nothing to check (yes); so is ``upright`` as a
                     during constraint ("while it is carried"): a pen let go leaning in the holder is fine
over, aimed          when the lower end is low (below the rim box's bottom edge, the rim's front edge in
                     the picture, less ``approach``): its horizontal image offset from the rim box's
                     centre within ``max_offset``; the container hidden: no sign of a miss (yes)
inside, shelved      the lower end inside the rim box horizontally, between the rim box's middle and
                     the container body's bottom edge vertically
freed                the item (centre or axis) farther than ``release_dist`` from the grasp point
=================== ==================================================================================

The mistakes of one image (and of these rules), on purpose: offsets and tilts along the viewing ray
are invisible (a pen tilted towards the camera looks upright, a tip 2 cm in front of the opening looks
"over" it); an item lying on the table along the ray behind a raised gripper looks "in the gripper";
a pen lying on the table pointing at the camera projects onto the image vertical and looks "upright";
a lower end just above the opening and one just inside it differ by a pixel or two; "low" is read
against the rim's front edge in the picture, so an end nearer the camera than the container looks low
early, and one at rim height over the back of the opening looks high; the arm and the
fingers hide parts of the item; a single frame cannot see an item turned or slid (``aligned``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from code_as_monitor.baselines.vqa_pixels import VQAAnswer, color_mask
from code_as_monitor.core.constraints import Constraint, Phase
from code_as_monitor.core.observation import View

ITEM_COLORS: dict[str, tuple[str, ...]] = {"pen": ("blue", "yellow"), "book": ("red", "cream")}
"""Colours (keys of ``HSV_RANGES``) of a graspable item's pixels."""
CONTAINER_COLORS: dict[str, tuple[str, str]] = {"holder": ("orange", "green"), "shelf": ("teal", "wood")}
"""(rim colour, body colour) of a container."""
MIN_ELONGATION = 1.25
"""A blob has a readable axis when its long side is at least 1.25 x its short side (sqrt of the PCA
eigenvalue ratio). From the front camera (~30-45 degrees down) an upright pen is ~10:1, an upright book
edge-on ~5:1 and face-on ~1.4:1 (20 cm tall, foreshortened to ~17, against 12 cm wide); a flat book
seen end-on is ~1:1 (20 cm x sin(30 degrees) + 2.4 cm against 12 cm). Rounder blobs are seen end-on or
mostly hidden."""
MIN_PIXELS = 12
"""Fewer item pixels than this and the item counts as not visible (a 1 cm pen end is ~10 px)."""


@dataclass(frozen=True)
class Shape:
    """An item's pixels in one image: centre (u, v) px, unit principal axis (pointing down the image),
    elongation (long/short, sqrt of the PCA eigenvalue ratio), lower and upper ends along the axis
    (u, v) px, pixel count."""

    u: float
    v: float
    axis: tuple[float, float]
    elongation: float
    low: tuple[float, float]
    area: int
    high: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class Box:
    """A container's image box (px): the rim colour's bounding box and the body's bottom edge."""

    left: float
    top: float
    right: float
    bottom: float
    body_bottom: float

    @property
    def cu(self) -> float:
        return 0.5 * (self.left + self.right)

    @property
    def cv(self) -> float:
        return 0.5 * (self.top + self.bottom)


@dataclass(frozen=True)
class Gripper:
    """The grasp point as the picture shows it: image position (u, v) px, pixels per metre at its depth,
    height above the table (m, proprioception). ``uv`` is None when it is behind the camera or unknown.
    ``jaw``: the jaw opening (m, the fingers' distance, proprioception), None without finger points."""

    uv: np.ndarray | None
    px_per_m: float
    z: float
    jaw: float | None = None


def item_kind(obj: str) -> str | None:
    """``"pen"``/``"book"`` for a graspable item's name, ``"holder"``/``"shelf"`` for a container's."""
    if "holder" in obj:
        return "holder"
    if "shelf" in obj:
        return "shelf"
    if obj == "pen" or obj.endswith("_pen"):
        return "pen"
    if obj == "book" or obj.endswith("_book"):
        return "book"
    return None


def _mask(rgb: np.ndarray, colors: tuple[str, ...]) -> np.ndarray:
    """(H, W) bool: pixels of any of ``colors``, without speckle (connected pieces under 3 pixels)."""
    import cv2

    m = np.zeros(rgb.shape[:2], dtype=bool)
    for c in colors:
        m |= color_mask(rgb, c)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(m.astype(np.uint8), connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= 3
    keep[0] = False
    return keep[labels]


def shape_of(rgb: np.ndarray, item: str) -> Shape | None:
    """The item's :class:`Shape` from its colours, or None when fewer than :data:`MIN_PIXELS` show."""
    vs, us = np.nonzero(_mask(rgb, ITEM_COLORS[item]))
    if len(us) < MIN_PIXELS:
        return None
    pts = np.stack([us, vs], axis=1).astype(float)
    c = pts.mean(axis=0)
    evals, evecs = np.linalg.eigh(np.cov((pts - c).T) + 1e-6 * np.eye(2))
    axis = evecs[:, 1]
    if axis[1] < 0:
        axis = -axis
    proj = (pts - c) @ axis
    low = c + axis * float(np.percentile(proj, 98))
    high = c + axis * float(np.percentile(proj, 2))
    elong = float(np.sqrt(evals[1] / max(evals[0], 1e-6)))
    return Shape(float(c[0]), float(c[1]), (float(axis[0]), float(axis[1])), elong,
                 (float(low[0]), float(low[1])), len(us), (float(high[0]), float(high[1])))


def box_of(rgb: np.ndarray, container: str) -> Box | None:
    """The container's rim box and body bottom from its two colours, or None when its rim is not visible."""
    rim_c, body_c = CONTAINER_COLORS[container]
    rim = _mask(rgb, (rim_c,))
    vs, us = np.nonzero(rim)
    if len(us) < MIN_PIXELS:
        return None
    bvs = np.nonzero(_mask(rgb, (body_c,)))[0]
    bottom = float(max(vs.max(), bvs.max() if len(bvs) else vs.max()))
    return Box(float(us.min()), float(vs.min()), float(us.max()), float(vs.max()), bottom)


def image_down(view: View, uv: tuple[float, float]) -> np.ndarray:
    """(2,) unit image direction of world -z (down) at pixel ``uv``: towards the camera's vertical
    vanishing point (every vertical line in the picture passes through it)."""
    cam = view.camera
    d = cam.T_cam_world[:3, :3] @ np.array([0.0, 0.0, -1.0])
    h = cam.K @ d
    out = h[:2] - np.asarray(uv, float) * h[2]
    n = float(np.linalg.norm(out))
    return out / n if n > 1e-9 else np.array([0.0, 1.0])


def tilt_deg(view: View, s: Shape) -> float:
    """Angle (degrees) between the blob's axis and the image direction of world vertical at its centre."""
    c = abs(float(np.dot(np.asarray(s.axis), image_down(view, (s.u, s.v)))))
    return float(np.degrees(np.arccos(min(1.0, c))))


def _near(s: Shape, g: Gripper, dist_m: float, line: bool = False) -> bool:
    """The item within ``dist_m`` (converted to pixels at the grasp point's depth) of the grasp point in
    the image: its centre, or with ``line`` its axis segment (a pen held near one end is still held)."""
    if g.uv is None:
        return False
    p = np.asarray(g.uv, float)
    if line:
        a, b = np.asarray(s.high), np.asarray(s.low)
        t = float(np.clip(np.dot(p - a, b - a) / max(float(np.dot(b - a, b - a)), 1e-9), 0.0, 1.0))
        q = a + t * (b - a)
    else:
        q = np.array([s.u, s.v])
    return float(np.linalg.norm(p - q)) <= dist_m * g.px_per_m


def _in_opening(s: Shape, b: Box) -> bool:
    """2-D "its lower end is down in the opening": inside the rim box sideways, below the rim box's
    middle (the opening's centre line) and above the body's bottom edge."""
    u, v = s.low
    return b.left <= u <= b.right and b.cv <= v <= b.body_bottom


def _nice(obj: str) -> str:
    return obj.replace("_", " ")


class GripperRules:
    """Answers the pen and book families' constraints on one front image (see the module docstring)."""

    def answer(self, key: str, c: Constraint, view: View, g: Gripper) -> VQAAnswer | None:
        """Yes/no for constraint ``c`` (kind ``key``), or None when it is not a pen/book constraint."""
        A = VQAAnswer

        objs = [p.obj for p in c.parts if p.obj != "robot"]
        items = [o for o in objs if item_kind(o) in ITEM_COLORS]
        if not items:
            return None
        obj = items[0]
        item = item_kind(obj) or ""
        target = next((o for o in objs if item_kind(o) in CONTAINER_COLORS), "")
        th = c.thresholds
        s = shape_of(view.rgb, item)
        n, t = _nice(obj), _nice(target)
        if s is None:
            if key == "freed":
                return A(True, f"{n} is not visible near the gripper")
            return A(False, f"cannot see {n} in the image; it may have been moved or dropped")
        # the constraint's element of the item: a LINE (the pen's axis) or a point (the book's centre)
        line = any(p.obj == obj and str(getattr(p.kind, "value", p.kind)) == "line" for p in c.parts)
        max_dist = float(th.get("max_dist", 0.04))
        held = _near(s, g, max_dist, line)
        if key in ("steady", "aligned"):
            down = g.uv is not None and g.z <= max_dist  # the grasp point as low as an item between the fingers
            if key == "steady" and down and not _near(s, g, max_dist + float(th.get("max_disp", 0.0)), line):
                return A(False, f"the fingers are down at the table but {n} is not between them; it moved")
            return A(True, f"{n} lies on the table (one image shows no motion)")
        if key == "grasped":
            return (A(True, f"{n} is between the fingers") if held
                    else A(False, f"{n} is not in the gripper"))
        if key in ("lifted", "raised"):  # raised: one image has no "where it began"; read as lifted
            up = g.z >= float(th.get("min_z", 0.05 + float(th.get("min_rise", 0.0))))
            return (A(True, f"{n} is lifted in the gripper") if held and up
                    else A(False, f"{n} is not lifted: not in the gripper or still low"))
        if key in ("gripped", "carried", "conveyed"):
            if held:
                return A(True, f"{n} is in the gripper")
            b = box_of(view.rgb, item_kind(target) or "") if target else None
            if key != "gripped" and b is not None and _in_opening(s, b):
                return A(True, f"{n} is already down in the opening of {t}")
            return A(False, f"{n} dropped: it is no longer held by the gripper")
        if key in ("upright", "standing", "poised"):
            # "while held/carried" (poised, and upright as a during constraint): let go, nothing to check
            if (key == "poised" or (key == "upright" and c.phase is Phase.DURING)) and not held:
                return A(True, f"{n} is not held any more; nothing to check")
            tilt = tilt_deg(view, s)
            limit = float(np.degrees(float(th.get("max_tilt", 0.26))))
            if s.elongation < MIN_ELONGATION:
                return A(False, f"{n} is not clearly upright (its outline has no clear long axis)")
            return (A(True, f"{n} looks upright ({tilt:.0f} degrees from vertical in the image)") if tilt <= limit
                    else A(False, f"{n} is tilted: {tilt:.0f} degrees from vertical in the image"))
        b = box_of(view.rgb, item_kind(target) or "") if target else None
        if key in ("over", "aimed") and b is None:  # conditional on a height it cannot judge: no sign of a miss
            return A(True, f"cannot see the opening of {t} (hidden); no sign that {n} misses it")
        if key in ("inside", "shelved") and b is None:
            return A(False, f"cannot see the opening of {t} in the image")
        if key in ("over", "aimed"):
            assert b is not None
            approach_px = float(th.get("approach", 0.03)) * g.px_per_m
            if s.low[1] < b.bottom - approach_px:
                return A(True, f"{n} is still high above {t}")
            off_px = abs(s.low[0] - b.cu)
            tol_px = float(th.get("max_offset", 0.015)) * g.px_per_m
            return (A(True, f"the lower end of {n} is above the opening of {t}") if off_px <= tol_px
                    else A(False, f"the lower end of {n} is low but not above the opening of {t} "
                                  f"({off_px / max(g.px_per_m, 1e-9) * 100:.0f} cm to the side in the image): "
                                  f"it will miss"))
        if key in ("inside", "shelved"):
            assert b is not None
            return (A(True, f"{n} is down in the opening of {t}") if _in_opening(s, b)
                    else A(False, f"{n} is not inside {t}"))
        if key == "freed":
            far = not _near(s, g, float(th.get("release_dist", 0.05)), line)
            return (A(True, f"{n} is released: the gripper is away from it") if far
                    else A(False, f"{n} is still held by the gripper"))
        return A(True, f"no visible problem with {n}")


__all__ = ["CONTAINER_COLORS", "ITEM_COLORS", "Box", "Gripper", "GripperRules", "Shape", "box_of", "image_down",
           "item_kind", "shape_of", "tilt_deg"]
