"""One constraint element from its instance and part masks on every view (the painter's default source).

Which masks build a part's element:

- a part some view shows with at least ``min_pixels`` pixels: its part masks alone (falling back to the whole
  object in a view that sees the part too small would pull the element off the part);
- a part no view shows that well (a rope's bead covers 4-11 pixels a view at 320x240): its part masks in the views
  showing at least a quarter of ``min_pixels``, when those views show ``min_pixels`` together, or, for a point
  element, when they bound every side of the part (no side of its fitted box assumed: a small part seen whole). Such
  an element has few points and is weak (:meth:`~code_as_monitor.core.elements.ElementSupport.weak`), but it is where
  the part is: the whole rope standing in for a bead put it 2-14 cm off, at the rope's centre, and checks and
  trackers read it as the bead. A few pixels give a centre, not a direction or a normal: a book's spine seen end-on
  in the front view alone, 4-11 pixels with its sides "bounded" by the book's other parts, read 90 degrees off as a
  line; lines and surfaces keep the whole object's stand-in there;
- otherwise (no pixels of the part, or a few that leave sides unbounded: a sliver of a hidden part, such as a book's
  cover above the slot it stands in, 44 mm off when built from its 6 pixels) the whole object's masks stand in,
  and the element says so (``support.part_seen`` False).

A view showing the element's mask with too few pixels to add points still carves with those pixels as the element's
own and, for a part, the object's other parts as its siblings (:class:`~code_as_monitor.geometry.carve.CarveView`):
taken for another object's surface, a book's spine and cover seen in the front view as a few pixels stopped the spine's
carving at them, and its line lay across its top, called sound.

``views``: per view ``(View, LiftedView, SegmentResult)``; masks are (H, W) bool in the view's image; elements in
the world frame, metres.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from code_as_monitor.core.elements import Element, ElementKind, ElementSpec
from code_as_monitor.core.errors import CamError

if TYPE_CHECKING:
    from code_as_monitor.geometry.support import SupportPlane

log = logging.getLogger(__name__)


def mask_element(eid: int, spec: ElementSpec, views: list[tuple], support: SupportPlane | None,
                 robots: list[np.ndarray | None] | None, min_pixels: int) -> Element | None:
    """Element ``eid`` of ``spec`` from ``views`` (see the module docstring for which masks); ``robots``: the
    robot's (H, W) bool mask per view (None: unknown); ``support``: the table plane. None when nothing is seen or
    the geometry cannot build it."""
    counts = [(int(np.count_nonzero(r.part_mask)), int(np.count_nonzero(r.instance_mask))) for _, _, r in views]
    if not spec.part or any(pc >= min_pixels for pc, _ in counts):
        return _fit(eid, spec, views, counts, min_pixels, min_pixels, support, robots)
    few = max(1, min_pixels // 4)
    enough = sum(pc for pc, _ in counts if pc >= few) >= min_pixels
    if enough or spec.kind is ElementKind.POINT:  # a line or surface from too few pixels is not tried at all
        el = _fit(eid, spec, views, counts, few, min_pixels, support, robots)
        if el is not None and el.support is not None and el.support.part_seen and (enough or el.support.assumed == 0):
            return el
    return _fit(eid, spec, views, counts, min_pixels, min_pixels, support, robots)


def _fit(eid: int, spec: ElementSpec, views: list[tuple], counts: list[tuple[int, int]], least: int,
         min_pixels: int, support: SupportPlane | None, robots: list[np.ndarray | None] | None) -> Element | None:
    """The element from the part's masks in the views showing at least ``least`` of its pixels or, when none does,
    from the whole object's masks in the views showing ``min_pixels`` of it; ``counts``: (part, instance) pixels
    per view."""
    from code_as_monitor.geometry import build_element_from_clouds, cap_cloud
    from code_as_monitor.geometry.carve import CarveView
    from code_as_monitor.geometry.part_cloud import fuse_part

    part_seen = bool(spec.part) and any(pc >= least for pc, _ in counts)
    clouds, carve_views = [], []
    robots = robots if robots is not None else [None] * len(views)
    for (view, lifted, res), (pc, ic), robot in zip(views, counts, robots):
        own = part_seen or pc >= least
        mask = res.part_mask if own else res.instance_mask
        # a view showing too little adds no points, but its carving still knows which pixels are the element's own
        # and which its siblings' (else a book's spine seen as a few pixels end-on in one view stops growing at
        # its own pixels and its cover's, read as another object just in front)
        few = (pc < least) if own else (ic < min_pixels)
        clouds.append(np.empty((0, 3)) if few else lifted.points(mask))
        siblings = res.instance_mask & ~res.part_mask if spec.part and own else None
        carve_views.append(CarveView(np.asarray(mask, dtype=bool), view.depth, view.camera, siblings, robot))
    if not any(len(c) for c in clouds):
        return None
    try:
        el = build_element_from_clouds(eid, spec, clouds, carve_views, support)
    except CamError as exc:
        log.info("element %d (%s) could not be built: %s", eid, spec.name, exc)
        return None
    if spec.part and not part_seen and el.support is not None:
        el.support = replace(el.support, part_seen=False)
    if not spec.part or not part_seen:
        el.object_cloud = el.cloud
    else:
        whole = [lifted.points(r.instance_mask) for (_, lifted, r), (_, ic) in zip(views, counts) if ic >= min_pixels]
        try:
            Q, vs, _ = fuse_part(whole, [], name=f"object of {spec.name!r}")
            el.object_cloud = cap_cloud(Q, voxel=vs)
        except CamError:
            el.object_cloud = None
    return el

