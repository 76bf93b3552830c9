"""The static table drawn once per camera and composed under every frame: the same pixels for less rendering.

PyBullet's TinyRenderer shades every pixel a body covers, and the table covers most of every view: in a
320 x 240 frame of the default views it costs about half the render (measured by ``benchmarks/sim_speed.py``,
``render_backdrop_*``). The table never moves, never changes colour and casts no shadow (cameras render with
``shadow=0``), and the renderer shades each triangle on its own, so a frame is the per-pixel nearest of two
renders: the scene without the table (its visual made fully transparent in the world's client, which the
TinyRenderer skips) and the table alone, rendered once per camera pose in a second client that holds nothing
else. :func:`compose` takes the scene's pixel where its depth-buffer value is at most the table's, else the
table's pixel.

Where the two renders are the same: everywhere but at exact depth ties, a surface lying in the table's top plane.
There the one-client render itself is arbitrary (a flat box whose top is the plane z = 0, seen from the top view:
all 6889 of its pixels tie, the one-client render shows the box on 6264 and the table on 625; :func:`compose` shows
the box on all). No task's scene has such a surface: ``tests/sim/test_backdrop.py`` renders every task's scene
both ways along a scripted episode and requires every RGB, depth and segmentation pixel to be equal (all 12 tasks,
724 frames, 0 pixels differ, 0 ties; ``benchmarks/sim_speed.py`` prints the render times). Only the TinyRenderer
path uses this; the EGL renderer draws the table itself.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import numpy as np

RawImages = tuple[np.ndarray, np.ndarray, np.ndarray]
"""One ``getCameraImage`` result as arrays: rgba (H, W, 4) uint8, z-buffer (H, W) float64 in [0, 1] (1 = nothing),
seg (H, W) int32 (PyBullet's object + link ids, -1 = nothing)."""

CACHE_SIZE = 8
"""Backdrop renders kept (keyed by camera size and matrices): every world-fixed view hits; a wrist view, whose pose
changes every frame, renders the table each time."""


def raw_images(client: int, width: int, height: int, view: list[float], proj: list[float]) -> RawImages:
    """One TinyRenderer frame of ``client`` (no shadows, object + link segmentation) as arrays."""
    import pybullet as pb

    _, _, rgba, zbuf, seg = pb.getCameraImage(
        width, height, viewMatrix=view, projectionMatrix=proj, renderer=pb.ER_TINY_RENDERER,
        flags=pb.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX, shadow=0, physicsClientId=client,
    )
    return (np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4)),
            np.reshape(np.asarray(zbuf, dtype=np.float64), (height, width)),
            np.reshape(np.asarray(seg, dtype=np.int64), (height, width)).astype(np.int32))


def compose(scene: RawImages, table: RawImages) -> RawImages:
    """Per pixel, the scene's pixel where its z-buffer value is at most the table's, else the table's (a tie, which
    no task's scene has, goes to the scene: see the module docstring)."""
    s_rgba, s_z, s_seg = scene
    t_rgba, t_z, t_seg = table
    front = s_z <= t_z
    return (np.where(front[:, :, None], s_rgba, t_rgba), np.where(front, s_z, t_z), np.where(front, s_seg, t_seg))


_BY_CLIENT: dict[int, Backdrop] = {}
"""The backdrop of each world client that has one (:func:`register`), so that a camera made on that client without
naming a backdrop (``SimCamera(spec, world.client, world.renderer)``) composes the table too."""


def register(client: int, backdrop: Backdrop) -> None:
    """Record ``backdrop`` as the one of world client ``client``."""
    _BY_CLIENT[client] = backdrop


def unregister(client: int) -> None:
    """Forget client ``client``'s backdrop (the world closed; PyBullet may give the id to a new client)."""
    _BY_CLIENT.pop(client, None)


def for_client(client: int) -> Backdrop | None:
    """The backdrop registered for world client ``client``, if any."""
    return _BY_CLIENT.get(client)


class Backdrop:
    """A second PyBullet client holding only the table, at the same pose as in the world (see the module docstring).

    Args:
        urdf: the table's URDF.
        position: its base position in the world (m).
        seg_value: the segmentation value the table has in the world's renders (its body id there, link -1), which
            the backdrop's table pixels are given.
    """

    def __init__(self, urdf: Path, position: tuple[float, float, float], seg_value: int) -> None:
        import pybullet as pb

        self.client = pb.connect(pb.DIRECT)
        pb.loadURDF(str(urdf), list(position), useFixedBase=True, physicsClientId=self.client)
        self.seg_value = seg_value
        self.renders = 0
        """Table renders made (cache misses)."""
        self._cache: OrderedDict[tuple, RawImages] = OrderedDict()

    def images(self, width: int, height: int, view: list[float], proj: list[float]) -> RawImages:
        """The table alone as ``raw_images`` gives it, from a cache of the last :data:`CACHE_SIZE` camera poses."""
        key = (width, height, tuple(view), tuple(proj))
        hit = self._cache.get(key)
        if hit is None:
            rgba, z, seg = raw_images(self.client, width, height, view, proj)
            seg = np.where(seg >= 0, np.int32(self.seg_value), seg).astype(np.int32)
            hit = self._cache[key] = (rgba, z, seg)
            self.renders += 1
            while len(self._cache) > CACHE_SIZE:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return hit

    def close(self) -> None:
        """Disconnect the backdrop's client (idempotent)."""
        import pybullet as pb

        if self.client >= 0:
            pb.disconnect(physicsClientId=self.client)
            self.client = -1
