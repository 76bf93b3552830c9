"""The robot as an occluder (geometry.occlusion) on constructed top-down depth images: a 4 cm block on a table seen
from 1 m above; a robot slab drawn in front of it covers none, half or all of it."""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.geometry.occlusion import OccluderView, contradiction, robot_hidden_fraction, robot_hidden_points
from code_as_monitor.geometry.solid import Box

CAM = CameraModel.look_at("top", np.array([0.0, 0.0, 1.0]), np.zeros(3), 320, 240, 20.0, up=np.array([1.0, 0.0, 0.0]))
BOX = Box(np.eye(3), np.array([-0.02, -0.02, 0.0]), np.array([0.02, 0.02, 0.04]))


def _pixels_of(x0: float, x1: float, y0: float, y1: float, z: float) -> np.ndarray:
    """(H, W) bool: the pixels whose ray meets the horizontal rectangle [x0, x1] x [y0, y1] at height z."""
    H, W = CAM.height, CAM.width
    vv, uu = np.mgrid[0:H, 0:W]
    Kinv = np.linalg.inv(CAM.K)
    rays = np.stack([uu.ravel(), vv.ravel(), np.ones(H * W)], 1) @ Kinv.T @ CAM.T_world_cam[:3, :3].T
    o = CAM.position
    s = (z - o[2]) / rays[:, 2]
    P = o + s[:, None] * rays
    inside = (P[:, 0] >= x0) & (P[:, 0] <= x1) & (P[:, 1] >= y0) & (P[:, 1] <= y1)
    return inside.reshape(H, W)


def _scene(robot_x1: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(depth, block mask, robot mask): table at z = 0, block top at 0.04, a robot slab at z = 0.2 over
    x in [-0.1, robot_x1] (None: no robot)."""
    depth = np.full((CAM.height, CAM.width), 1.0)
    block = _pixels_of(-0.02, 0.02, -0.02, 0.02, 0.04)
    depth[block] = 0.96
    robot = np.zeros_like(block)
    if robot_x1 is not None:
        robot = _pixels_of(-0.1, robot_x1, -0.1, 0.1, 0.2)
        depth[robot] = 0.8
    return depth, block & ~robot, robot


def test_no_robot_in_front_hides_nothing_and_a_view_without_robot_mask_says_nothing() -> None:
    depth, block, robot = _scene(None)
    assert robot_hidden_fraction(BOX, [OccluderView(depth, CAM, robot, block)]) == 0.0
    depth, block, robot = _scene(0.1)
    assert robot_hidden_fraction(BOX, [OccluderView(depth, CAM, None, block)]) == 0.0


def test_the_hidden_fraction_grows_with_the_robot_over_the_block() -> None:
    fr = []
    for x1 in (-0.05, 0.0, 0.1):
        depth, block, robot = _scene(x1)
        fr.append(robot_hidden_fraction(BOX, [OccluderView(depth, CAM, robot, block)]))
    assert fr[0] == 0.0
    assert 0.3 < fr[1] < 0.7, fr  # the slab ends over the block's middle
    assert fr[2] > 0.95, fr


def test_a_robot_behind_the_block_does_not_hide_it() -> None:
    depth, block, _ = _scene(None)
    robot = _pixels_of(-0.1, 0.1, -0.1, 0.1, 0.0) & ~block  # "robot" on the table around the block, not in front
    assert robot_hidden_fraction(BOX, [OccluderView(depth, CAM, robot, block)]) == 0.0


def _skin() -> np.ndarray:
    g = np.linspace(-0.015, 0.015, 7)
    return np.array([[x, y, 0.04] for x in g for y in g])


def test_a_remembered_block_where_it_is_is_not_contradicted_and_a_moved_one_is() -> None:
    depth, block, robot = _scene(0.0)  # the robot hides half of the block
    views = [OccluderView(depth, CAM, robot, block)]
    visible = _skin()[_skin()[:, 0] > 0.005]
    seen, outside = contradiction(_skin(), np.array([0.0, 0.0, 0.02]), visible, views)
    assert seen == 0.0 and outside == 0.0
    moved = _skin() + np.array([0.0, 0.03, 0.0])  # remembered 3 cm off: the views see the table where it would be
    seen, outside = contradiction(moved, np.array([0.0, 0.03, 0.02]), visible, views)
    assert seen > 0.2 and outside > 0.2, (seen, outside)


def test_a_remembered_block_the_robot_covers_entirely_is_hidden_not_contradicted() -> None:
    depth, block, robot = _scene(0.1)
    views = [OccluderView(depth, CAM, robot, block)]
    assert robot_hidden_points(_skin(), views) == 1.0
    seen, outside = contradiction(_skin(), np.array([0.0, 0.0, 0.02]), np.empty((0, 3)), views)
    assert seen == 0.0 and outside == 0.0
    assert robot_hidden_points(_skin(), [OccluderView(*_scene(None)[:1], CAM, _scene(None)[2], None)]) == 0.0


def test_the_share_the_robot_hides_leaves_out_what_the_part_shows_of_itself() -> None:
    """Half the remembered block is seen (its own pixels), the other half is under the robot: all of what the part
    does not show of itself is hidden. Without the part's mask the seen half counts as not hidden; a part seen whole
    leaves the robot nothing to hide."""
    depth, block, robot = _scene(0.0)
    assert robot_hidden_points(_skin(), [OccluderView(depth, CAM, robot, block)]) == 1.0
    assert 0.3 < robot_hidden_points(_skin(), [OccluderView(depth, CAM, robot, None)]) < 0.7
    depth, block, robot = _scene(None)
    assert robot_hidden_points(_skin(), [OccluderView(depth, CAM, robot, block)]) == 0.0


def test_a_skin_on_the_silhouettes_border_is_not_seen_through_but_one_beyond_it_is() -> None:
    """A mask's outline is known to a pixel: a remembered point projecting just past it (a thin part's skin seen
    edge-on) is not "seen past"; two pixels further it is."""
    depth, block, robot = _scene(None)
    views = [OccluderView(depth, CAM, robot, block)]
    rows, cols = np.nonzero(block)
    r, c = int(np.median(rows)), int(cols.max())
    Kinv = np.linalg.inv(CAM.K)

    def at_pixel(u: float, v: float) -> np.ndarray:
        """(1, 3) the point at the block top's height (z 0.04) that pixel (u, v) sees."""
        ray = CAM.T_world_cam[:3, :3] @ (Kinv @ np.array([u, v, 1.0]))
        s = (0.04 - CAM.position[2]) / ray[2]
        return (CAM.position + s * ray)[None]

    border, beyond = at_pixel(c + 1, r), at_pixel(c + 3, r)  # the table 4 cm below reads past both
    assert contradiction(border, border[0], np.empty((0, 3)), views)[0] == 0.0
    assert contradiction(beyond, beyond[0], np.empty((0, 3)), views)[0] == 1.0


def _footprint_whole_image(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference: the projected hull filled on a whole (H, W) image."""
    import cv2

    uv, _ = CAM.project(corners)
    img = np.zeros((CAM.height, CAM.width), dtype=np.uint8)
    cv2.fillConvexPoly(img, cv2.convexHull(np.rint(uv).astype(np.int32)), 1)
    return np.nonzero(img)


def test_a_box_footprint_is_the_pixels_of_its_projected_hull_also_across_the_image_border() -> None:
    from code_as_monitor.geometry.occlusion import _footprint, box_corners

    rng = np.random.default_rng(5)
    n = 0
    for _ in range(60):  # boxes inside, across the border of and partly outside the 320x240 view
        c = rng.uniform(-0.3, 0.3, 3) * np.array([1.0, 1.0, 0.5])
        axes = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        half = rng.uniform(0.005, 0.15, 3)
        lo = c @ axes.T - half
        corners = box_corners(Box(axes, lo, lo + 2 * half))
        fp = _footprint(corners, CAM, (CAM.height, CAM.width))
        want = _footprint_whole_image(corners)
        if fp is None:
            assert len(want[0]) == 0
            continue
        (r, cols), _ = fp
        assert np.array_equal(r, want[0]) and np.array_equal(cols, want[1])
        n += len(r) > 0
    assert n > 40
