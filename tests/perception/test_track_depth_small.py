"""The depth tracker's tracking by detection of small objects, on analytic RGB-D scenes: a pile of small
blocks pushed together, a rope's beads moving together, an occluded bead (stale, then re-acquired) and two
beads passing close. The tracker sees depth, the cameras, the robot state and the segmenter's masks in an
order shuffled every frame (anonymous instances); the tests know the true boxes."""

from __future__ import annotations

import numpy as np
import pytest
from perception_synth import Box, Scene, observe, two_cameras

from code_as_monitor.core.elements import Element, ElementSpec
from code_as_monitor.core.errors import ConfigError
from code_as_monitor.core.observation import Observation
from code_as_monitor.painter import Painter
from code_as_monitor.perception import SegmenterConfig, make_segmenter
from code_as_monitor.perception.trackers.base import DepthTrackerConfig, TrackerConfig, make_tracker
from code_as_monitor.perception.trackers.depth_detect import is_small

BLOCK = 0.02
BEAD = 0.01  # a bead this size leaves fewer than 30 points after the 3 mm voxel grid


class RopeScene(Scene):
    """Boxes named ``bead_NN`` are the parts of one object ``rope``; the others are objects of their own."""

    def labels(self) -> dict[int, tuple[str, str]]:
        out = super().labels()
        for j, b in enumerate(self.boxes):
            if b.name.startswith("bead_"):
                out[10 + 2 * j] = out[11 + 2 * j] = ("rope", b.name)
        return out


class Shuffled:
    """The sim segmenter with its results returned in a new random order every call: which query a mask
    answers is not to be relied on."""

    def __init__(self) -> None:
        self.inner = make_segmenter(SegmenterConfig.from_name("sim"))
        self.rng = np.random.default_rng(0)

    def segment_many(self, view, specs, texts=None):
        res = self.inner.segment_many(view, specs, texts)
        return [res[i] for i in self.rng.permutation(len(res))]


def _obs(scene: Scene, cams, t: float, tip=(0.3, 0.3, 0.4)) -> Observation:
    obs = observe(scene, cams, t, tip=np.asarray(tip, float), with_poses=False)
    obs.robot.ee_pose[:3, :3] = np.diag([1.0, -1.0, -1.0])  # a tool pointing down
    return obs


def _track(scene: Scene, cams, specs: list[ElementSpec], tip=(0.3, 0.3, 0.4), segmenter=None):
    obs = _obs(scene, cams, 0.0, tip)
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    els = [painter.build_element(obs, i, s) for i, s in enumerate(specs)]
    assert all(e is not None for e in els)
    tr = make_tracker(TrackerConfig.from_name("depth"))
    tr.set_segmenter(Shuffled() if segmenter is None else segmenter)
    tr.reset(obs, els)
    return tr, els


def _stick() -> tuple[Box, Box]:
    """A 12 cm shaft lying on the table with a 1 cm tip at its +x end (the parts of one object ``stick``)."""
    shaft = Box("shaft", np.array([0.0, 0.0, 0.005]), np.array([0.12, 0.012, 0.01]), textured=False)
    tip = Box("tip", np.array([0.065, 0.0, 0.005]), np.full(3, 0.01), color=(40, 200, 40), textured=False)
    return shaft, tip


def _offsets(els: list[Element], boxes: list[Box]) -> list[np.ndarray]:
    """Each element's painted point relative to its true box centre (what the tracker must carry along)."""
    return [e.points[0] - b.center for e, b in zip(els, boxes)]


def _pile(n: int = 3) -> list[Box]:
    """An n x n pile of touching 2 cm blocks."""
    return [Box(f"block_{i * n + j:02d}", np.array([-0.02 + i * BLOCK, -0.03 + j * BLOCK, BLOCK / 2]),
                np.full(3, BLOCK), color=(200, 40, 40), textured=False) for i in range(n) for j in range(n)]


def test_small_is_measured_on_the_cloud_not_named():
    c = DepthTrackerConfig()
    rng = np.random.default_rng(1)
    assert is_small(rng.uniform(0, 0.02, (60, 3)), c)  # a 2 cm object
    assert is_small(rng.uniform(0, 0.1, (12, 3)), c)  # too few points whatever its size
    assert not is_small(rng.uniform(0, 0.06, (200, 3)), c)  # a 6 cm block is registered
    assert not is_small(rng.uniform(0, 0.02, (60, 3)), DepthTrackerConfig(detect_points=0, detect_extent=0.0))
    with pytest.raises(ConfigError, match="detect_reacquire_gate"):
        DepthTrackerConfig(detect_gate=2.0, detect_reacquire_gate=1.0)


def test_pile_of_small_blocks_pushed_together_is_followed():
    """Nine touching 2 cm blocks pushed together by the tool at 15 mm per frame, then at rest; a 6 cm block
    beside them is registered as before."""
    cams = two_cameras()
    pile = _pile()
    big = Box("big_block", np.array([0.08, 0.06, 0.03]), np.full(3, 0.06), color=(40, 60, 200), textured=False)
    scene = Scene([*pile, big], table_textured=False)
    specs = [ElementSpec(b.name, b.name, "") for b in [*pile, big]]
    tip0 = np.array([0.0, -0.03 - 1.5 * BLOCK, 0.01])  # just behind the pile
    tr, els = _track(scene, cams, specs, tip0)
    assert tr.detected_owners() == {(b.name, "") for b in pile}  # the 6 cm block is registered
    off = _offsets(els, [*pile, big])
    start = [b.center.copy() for b in pile]
    v = np.array([0.0, 0.015, 0.0])
    for f in range(1, 11):
        k = min(f, 7)  # pushed for 7 frames, then at rest
        for b, s in zip(pile, start):
            b.center = s + k * v
        res = tr.step(_obs(scene, cams, 0.1 * f, tip0 + k * v))
        for e, b, o in zip(els, [*pile, big], off):
            assert not res.stale[e.id].any(), (f, e.name)
            err = float(np.linalg.norm(res.points[e.id][0] - (b.center + o)))
            assert err < 0.004, (f, e.name, err)


def _rope(n: int, spacing: float = 0.012) -> list[Box]:
    return [Box(f"bead_{i:02d}", np.array([-0.08 + i * spacing, 0.0, BEAD / 2]), np.full(3, BEAD),
                color=(240, 130, 30), textured=False) for i in range(n)]


def _bead_specs(beads: list[Box]) -> list[ElementSpec]:
    return [ElementSpec(f"rope {b.name}", "rope", b.name) for b in beads]


def test_rope_beads_moving_together_are_followed():
    """A rope of eight 1 cm beads 12 mm apart dragged sideways and bent (each bead its own speed, up to
    12 mm per frame)."""
    cams = two_cameras()
    beads = _rope(8)
    scene = RopeScene(beads, table_textured=False)
    tr, els = _track(scene, cams, _bead_specs(beads))
    assert tr.detected_owners() == {("rope", b.name) for b in beads}
    off = _offsets(els, beads)
    start = [b.center.copy() for b in beads]
    for f in range(1, 11):
        for i, (b, s) in enumerate(zip(beads, start)):
            b.center = s + np.array([0.002 * f, (0.004 + 0.001 * i) * f, 0.0])
        res = tr.step(_obs(scene, cams, 0.1 * f))
        for e, b, o in zip(els, beads, off):
            assert not res.stale[e.id].any(), (f, e.name)
            err = float(np.linalg.norm(res.points[e.id][0] - (b.center + o)))
            assert err < 0.004, (f, e.name, err)


def test_occluded_bead_is_stale_then_reacquired():
    """A cup put over one bead for five frames while the bead slides 10 mm: stale at its last good point (no
    guess), then found again where it is. (Beads 6 cm apart here, so the cup hides no part of the others.)"""
    cams = two_cameras()
    beads = _rope(4, spacing=0.06)
    scene = RopeScene(beads, table_textured=False)
    tr, els = _track(scene, cams, _bead_specs(beads))
    assert len(tr.detected_owners()) == len(beads)
    off = _offsets(els, beads)
    hidden, e_h = beads[2], els[2]
    cup = Box("cup", hidden.center + np.array([0.0, 0.0, 0.002]), np.array([0.05, 0.05, 0.02]), color=(90, 90, 90),
              textured=False)
    last = None
    for f in range(1, 12):
        covered = 2 <= f <= 6
        scene.boxes = beads + ([cup] if covered else [])
        if covered:
            hidden.center = hidden.center + np.array([0.0, 0.002, 0.0])
        res = tr.step(_obs(scene, cams, 0.1 * f))
        if f == 1:
            last = res.points[e_h.id].copy()
        if covered:
            assert res.stale[e_h.id].all(), f
            np.testing.assert_allclose(res.points[e_h.id], last)  # its last good point, nothing guessed
        else:
            assert not res.stale[e_h.id].any(), f
            err = float(np.linalg.norm(res.points[e_h.id][0] - (hidden.center + off[2])))
            assert err < 0.004, (f, err)
        for e, b, o in zip(els, beads, off):
            if e.id != e_h.id:
                assert not res.stale[e.id].any(), (f, e.name)
                assert np.linalg.norm(res.points[e.id][0] - (b.center + o)) < 0.004, (f, e.name)


def test_two_beads_passing_close_keep_their_identities():
    """Two identical 1 cm beads on parallel lanes 13 mm apart pass each other head-on at 8 mm per frame each.
    The gate is one extent of the bead's painted cloud (about its size): the other bead is never nearer to a
    bead's prediction than its own detection, so the assignment of least total distance keeps them apart."""
    cams = two_cameras()
    a = Box("bead_00", np.array([-0.05, 0.0, BEAD / 2]), np.full(3, BEAD), color=(240, 130, 30), textured=False)
    b = Box("bead_01", np.array([0.05, 0.013, BEAD / 2]), np.full(3, BEAD), color=(240, 130, 30), textured=False)
    scene = RopeScene([a, b], table_textured=False)
    tr, els = _track(scene, cams, _bead_specs([a, b]))
    assert tr.detected_owners() == {("rope", "bead_00"), ("rope", "bead_01")}
    off = _offsets(els, [a, b])
    for f in range(1, 14):
        a.center = a.center + np.array([0.008, 0.0, 0.0])
        b.center = b.center - np.array([0.008, 0.0, 0.0])
        res = tr.step(_obs(scene, cams, 0.1 * f))
        for e, box, o in zip(els, [a, b], off):
            assert not res.stale[e.id].any(), (f, e.name)
            err = float(np.linalg.norm(res.points[e.id][0] - (box.center + o)))
            assert err < 0.004, (f, e.name, err)


def test_without_a_segmenter_small_bodies_are_registered():
    cams = two_cameras()
    beads = _rope(3)
    obs = _obs(RopeScene(beads, table_textured=False), cams, 0.0)
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    els = [painter.build_element(obs, i, s) for i, s in enumerate(_bead_specs(beads))]
    tr = make_tracker(TrackerConfig.from_name("depth"))
    tr.reset(obs, els)  # type: ignore[arg-type]
    assert tr.detected_owners() == set()


class StickScene(Scene):
    """Box ``shaft`` (long) and box ``tip`` (1 cm, at its end) are the parts of one object ``stick``."""

    def labels(self) -> dict[int, tuple[str, str]]:
        out = super().labels()
        for j, b in enumerate(self.boxes):
            out[10 + 2 * j] = out[11 + 2 * j] = ("stick", b.name)
        return out


def test_small_part_of_an_object_with_a_registrable_part_stays_registered():
    """A stick's 1 cm tip is small, but its 12 cm shaft is painted too: the tip moves with the registered
    stick (as before); painted alone, the tip is tracked by detection."""
    cams = two_cameras()
    shaft, tip = _stick()
    scene = StickScene([shaft, tip], table_textured=False)
    both = [ElementSpec("stick shaft", "stick", "shaft", "line"), ElementSpec("stick tip", "stick", "tip")]
    tr, _ = _track(scene, cams, both)
    assert tr.detected_owners() == set()
    tr, _ = _track(scene, cams, both[1:])
    assert tr.detected_owners() == {("stick", "tip")}


def test_a_part_built_from_its_whole_object_does_not_make_the_object_registrable():
    """A bead no view saw is painted from the whole rope's masks (``part_seen`` False): its rope-wide cloud
    does not count as a registrable element of the rope."""
    from code_as_monitor.core.elements import ElementKind, ElementSupport
    from code_as_monitor.perception.trackers.depth_detect import registrable_objects

    rng = np.random.default_rng(2)
    rope = rng.uniform(0, 0.3, (400, 3))

    def bead(i: int, cloud: np.ndarray, seen: bool) -> Element:
        return Element(i, f"bead {i}", ElementKind.POINT, cloud.mean(axis=0)[None], ("rope", f"bead_{i:02d}"),
                       cloud=cloud, object_cloud=rope, support=ElementSupport(len(cloud), 2, 0.001, part_seen=seen))

    c = DepthTrackerConfig()
    small = rng.uniform(0, 0.015, (20, 3))
    assert registrable_objects([bead(0, small, True), bead(1, rope, False)], c, None) == set()
    assert registrable_objects([bead(0, small, True), bead(1, rope, True)], c, None) == {"rope"}


class StickAndCubeScene(Scene):
    """Boxes ``shaft`` and ``tip`` are the parts of one object ``stick``; any other box is an object of its own."""

    def labels(self) -> dict[int, tuple[str, str]]:
        out = super().labels()
        for j, b in enumerate(self.boxes):
            if b.name in ("shaft", "tip"):
                out[10 + 2 * j] = out[11 + 2 * j] = ("stick", b.name)
        return out


def test_small_part_whose_object_is_lost_is_stale_not_fitted_elsewhere():
    """A stick's 1 cm tip is registered with its stick. While the stick moves a few mm per frame, the tip
    follows it; when the whole stick is lost (it leaves the crop at once), the tip alone would fit a
    1 cm cube 2 cm away that looks just like it: it must be stale at its last good point, not there."""
    cams = two_cameras()
    shaft, tip = _stick()
    cube = Box("cube", np.array([0.065, 0.02, 0.005]), np.full(3, 0.01), color=(40, 200, 40), textured=False)
    scene = StickAndCubeScene([shaft, tip, cube], table_textured=False)
    specs = [ElementSpec("stick shaft", "stick", "shaft", "line"), ElementSpec("stick tip", "stick", "tip")]
    tr, els = _track(scene, cams, specs)
    assert tr.detected_owners() == set()  # the tip is registered with its stick
    painted = els[1].points[0] - tip.center
    start = [shaft.center.copy(), tip.center.copy()]
    step = np.array([-0.004, 0.0, 0.0])  # away from the cube
    for f in range(1, 4):
        shaft.center, tip.center = start[0] + f * step, start[1] + f * step
        res = tr.step(_obs(scene, cams, 0.1 * f))
        assert not res.stale[els[1].id].any(), f
        assert np.linalg.norm(res.points[els[1].id][0] - (tip.center + painted)) < 0.003, f
    last = res.points[els[1].id].copy()
    away = np.array([0.0, -0.3, 0.0])  # the whole stick leaves at once: lost
    shaft.center, tip.center = shaft.center + away, tip.center + away
    for f in range(4, 7):
        res = tr.step(_obs(scene, cams, 0.1 * f))
        assert res.stale[els[0].id].all(), f  # the stick is lost ...
        assert res.stale[els[1].id].all(), f  # ... and so is its tip, not fitted to the cube
        np.testing.assert_allclose(res.points[els[1].id], last)


def test_a_part_repainted_from_its_whole_object_does_not_replace_the_part():
    """Re-acquiring a part that its paint had seen: a re-paint where no view saw the part (the whole object's
    masks stood in) is not the part's position (a pen tip inside the holder re-painted as the visible pen
    above it, 8 cm off); a part that was a stand-in from the start may be re-painted as one."""
    from code_as_monitor.core.elements import Element, ElementKind, ElementSupport, stood_in

    def el(part: str, seen: bool | None) -> Element:
        sup = None if seen is None else ElementSupport(points=40, views=2, residual=0.001, part_seen=seen)
        return Element(2, "pen tip", ElementKind.POINT, np.zeros((1, 3)), ("pen", part), support=sup)

    assert stood_in(el("tip", True), el("tip", False))
    assert stood_in(el("tip", None), el("tip", False))
    assert not stood_in(el("tip", True), el("tip", True))
    assert not stood_in(el("tip", False), el("tip", False))  # a stand-in all along
    assert not stood_in(el("", True), el("", False))  # a whole object is its own mask


def test_part_keeps_its_place_when_its_object_is_reacquired():
    """A stick (shaft and tip) jumps 6 cm along itself at once: lost. The hook re-paints the shaft but not the
    tip (as for a part no view sees: its re-paint would be its whole object standing in). The stick's known
    model is relocated onto its new segmentation, so the tip comes back where it is on the stick, not stale
    for good (a new model for the stick would drop the tip's relation to it)."""
    cams = two_cameras()
    shaft, tip = _stick()
    scene = StickAndCubeScene([shaft, tip], table_textured=False)
    specs = [ElementSpec("stick shaft", "stick", "shaft", "line"), ElementSpec("stick tip", "stick", "tip")]
    tr, els = _track(scene, cams, specs)
    painter = Painter(make_segmenter(SegmenterConfig.from_name("sim")))
    calls: list[int] = []

    def hook(obs, el):
        calls.append(el.id)
        return painter.build_element(obs, el.id, specs[el.id]) if el.id == 0 else None

    tr.set_reacquire(hook)
    painted = els[1].points[0] - tip.center
    jump = np.array([-0.06, 0.0, 0.0])
    shaft.center, tip.center = shaft.center + jump, tip.center + jump
    fresh = []
    for f in range(1, 10):
        res = tr.step(_obs(scene, cams, 0.1 * f))
        fresh.append(not res.stale[1].any())
    assert 0 in calls and 1 in calls and not fresh[0]  # both lost, both re-acquisitions asked for
    assert fresh[-1], fresh
    np.testing.assert_allclose(res.points[1][0], tip.center + painted, atol=0.003)
