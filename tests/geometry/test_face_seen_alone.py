"""A block in a tower seen on one face only: its centre is the block's centre, not a point on the face.

Analytic scene (ray-cast depth, exact masks): three 40 mm cubes stacked exactly on a table (yaw 20 degrees), seen
from the benchmark's front camera (1.15, 0, 0.65) m alone or with the top camera (0.5, 0, 1.5) m. The front view
sees only the front faces of the two lower blocks (their neighbours hide their tops and bottoms, their backs face
away); the top view sees the top block's top. The views prove the space in front of each face empty and nothing
behind it, so the depth behind a face seen alone is the documented compact-solid assumption (as deep as the
smaller of its two seen extents), bounded by what the views prove empty, and the element says so (assumed sides,
uncertainty).
"""

from __future__ import annotations

import numpy as np
import pytest

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.geometry import build_element, rotation_about
from code_as_monitor.geometry.raycast import Box, Plane, cast
from code_as_monitor.geometry.support import support_plane

HALF = 0.02
CENTRE_XY = np.array([0.45, -0.05])
YAW_DEG = 20.0
W, H = 320, 240
FRONT = CameraModel.look_at("front", np.array([1.15, 0.0, 0.65]), np.array([0.45, 0.0, 0.0]), W, H, 50.0)
TOP = CameraModel.look_at("top", np.array([0.5, 0.0, 1.5]), np.array([0.5, 0.0, 0.0]), W, H, 50.0)


def _tower(n: int = 3, shift: tuple[float, float] = (0.0, 0.0), centre: np.ndarray = CENTRE_XY,
           yaw_deg: float = YAW_DEG) -> list[Box]:
    """``n`` cubes stacked from the table up at ``centre`` (x, y), turned ``yaw_deg``; block k shifted by
    ``k * shift`` (metres, x and y)."""
    R = rotation_about([0.0, 0.0, 1.0], np.deg2rad(yaw_deg))
    return [Box(np.array([*(np.asarray(centre) + k * np.asarray(shift)), HALF + 2 * HALF * k]), np.full(3, HALF), R)
            for k in range(n)]


def _observations(blocks: list[Box], cams: list[CameraModel], k: int):
    """``(mask of block k, depth, camera)`` per camera, the table included in the depth."""
    table = Plane(0.0, (0.5, 0.0), (0.8, 0.8))
    out = []
    for cam in cams:
        depth, index, _ = cast([*blocks, table], cam)
        depth = np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)
        out.append((index == k, depth, cam))
    return out


def _paint(blocks: list[Box], cams: list[CameraModel], k: int, noise: float = 0.0, seed: int = 0):
    obs = _observations(blocks, cams, k)
    if noise > 0:
        rng = np.random.default_rng(seed)
        obs = [(m, np.where(d > 0, d + rng.normal(0.0, noise, d.shape), 0.0).astype(np.float32), c)
               for m, d, c in obs]
    support = support_plane([(d, c) for _, d, c in obs])
    return build_element(k, ElementSpec(f"block {k}", f"block_{k}", "", ElementKind.POINT), obs, support=support)


@pytest.mark.parametrize("cams", [[FRONT], [FRONT, TOP]], ids=["front", "front+top"])
@pytest.mark.parametrize("k", [0, 1])
def test_a_lower_block_seen_on_its_front_face_alone_is_centred(cams, k) -> None:
    blocks = _tower()
    mask = _observations(blocks, cams, k)[0][0]
    assert mask.sum() > 60  # the front view sees the face...
    e = _paint(blocks, cams, k)
    assert e.support.extent[2] > 0.03  # ...and the element is a solid, not the face
    assert np.linalg.norm(e.points[0] - blocks[k].center) < 0.004
    assert e.support.assumed >= 1 and e.support.weak()  # its depth is an assumption, and it says so
    assert e.support.uncertainty > 0.004  # how far the centre may be: the views do not bound the back


@pytest.mark.parametrize("seed", [0, 1])
def test_a_face_seen_alone_under_depth_noise(seed) -> None:
    blocks = _tower()
    e = _paint(blocks, [FRONT, TOP], 1, noise=0.002, seed=seed)
    assert np.linalg.norm(e.points[0] - blocks[1].center) < 0.006


def test_centred_pairs_read_centred() -> None:
    blocks = _tower()
    pts = [_paint(blocks, [FRONT, TOP], k).points[0] for k in range(3)]
    for lo, hi in ((0, 1), (1, 2)):
        assert np.linalg.norm(pts[hi][:2] - pts[lo][:2]) < 0.005


def test_an_offset_tower_reads_offset() -> None:
    """The assumption does not centre what is not centred: a middle block pushed 15 mm back reads pushed back.

    Only its horizontal position is checked: the top view then sees a strip of its top and of the lower block's
    top, and its bottom side grows down into the lower block, whose surfaces are more than the carving's shell
    from the samples (a limitation of the carving, not of the assumption: notes/elements.md)."""
    base = _tower(1)[0]
    R = base.R
    back = -R[:, 0] * 0.015  # along the block's own axis facing away from the front camera
    blocks = [base, Box(base.center + np.array([*back[:2], 2 * HALF]), base.half, R),
              Box(base.center + np.array([0.0, 0.0, 4 * HALF]), base.half, R)]
    e = _paint(blocks, [FRONT, TOP], 1)
    assert np.linalg.norm(e.points[0, :2] - blocks[1].center[:2]) < 0.004


def test_a_block_seen_on_two_faces_assumes_nothing() -> None:
    blocks = _tower(1)
    e = _paint(blocks, [FRONT, TOP], 0)
    assert np.linalg.norm(e.points[0] - blocks[0].center) < 0.003
    assert e.support.assumed == 0 and e.support.uncertainty < 0.003


SHOULDER = CameraModel.look_at("shoulder", np.array([0.3, 0.5, 0.75]), np.array([0.3, 0.0, 0.0]), W, H, 60.0)


@pytest.mark.parametrize("n", [2, 3])
@pytest.mark.parametrize("centre, yaw", [((0.35, 0.25), 45.0), ((0.45, 0.2), 0.0)])
def test_the_lowest_block_does_not_grow_into_the_block_on_it(n, centre, yaw) -> None:
    """A shoulder view (one of the element benchmark's, which the other tests never use) sees the lowest block's
    sides, not its top: the block on it covers that. The space above the lowest block, behind the upper block's
    faces, is no evidence that it is taller (before: its box 70-81 mm tall, its centre 13.8-19.0 mm high at
    (0.35, 0.25), 6.1 mm at (0.45, 0.2)). The element stays a block-sized solid at the block's centre, and says
    that its height is an assumption."""
    blocks = _tower(n, centre=np.array(centre), yaw_deg=yaw)
    e = _paint(blocks, [SHOULDER], 0)
    assert np.linalg.norm(e.points[0] - blocks[0].center) < 0.005
    assert max(e.support.extent) < 0.05
    assert e.support.assumed >= 1


TOP_NARROW = CameraModel.look_at("top", np.array([0.5, 0.0, 1.5]), np.array([0.5, 0.0, 0.0]), W, H, 32.0)
"""The simulator's own top view (32 degrees field of view)."""


def _pile(centre: tuple[float, float], yaw_deg: float, half: float = 0.01) -> list[Box]:
    """A 20 mm cube (index 0) with its eight neighbours touching it on a 3 x 3 grid, turned ``yaw_deg``: a pile of
    sweep-half's blocks, where only the middle block's top is in view."""
    R = rotation_about([0.0, 0.0, 1.0], np.deg2rad(yaw_deg))
    offsets = [(0, 0)] + [(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0)]
    return [Box(np.array([*(np.asarray(centre) + (R[:2, 0] * i + R[:2, 1] * j) * 2 * half), half]), np.full(3, half), R)
            for i, j in offsets]


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("centre, yaw", [((0.5, 0.0), 25.0), ((0.45, 0.1), 0.0), ((0.55, -0.1), 25.0)])
def test_a_small_block_seen_on_its_top_alone_under_depth_noise_says_so(centre, yaw, seed) -> None:
    """With 2 mm of depth noise a face's points span about 3.3 standard deviations along its normal (5-6 mm here),
    more than a quarter of a 20 mm block's width: before, the middle block of a pile was then taken for a solid 4-6 mm
    thick, measured, its centre 8-11 mm off and not flagged (sweep-half's worst elements under noise). The face-alone
    test now allows for the noise it measured: the block gets the compact-solid depth, an assumption it reports, and
    its centre is either close or uncertain by at least half its error (the element benchmark's "does the painter
    know?")."""
    blocks = _pile(centre, yaw)
    e = _paint(blocks, [FRONT, TOP_NARROW], 0, noise=0.002, seed=seed)
    err = float(np.linalg.norm(e.points[0] - blocks[0].center))
    assert err < 0.006 or (e.support.weak() and e.support.uncertainty >= err / 2), (err, e.support)
    assert e.support.assumed >= 1  # its height is not a measurement
