"""Elements handed over as unconnected 3-D points (the ablation "CP off", ``Painter(connect_points=False)``).

The painter builds each element as usual, then gives the coder, the tracker and the checks no line or surface:
a line becomes its two ends and a surface its corners, **each a point element of its own** (new ids, numbered in
the order of the elements they come from), named ``"<name> p<i>/<n>"`` (point i of the n the element had) and
owned by the same object and part. Every constraint's ``parts`` and ``element_ids`` are rewritten to list those
points, so a check receives only points and must recombine them itself (the paper: "standalone points require
recombination during visual programming"). The points are the ends and corners the full method would have
connected: what the switch removes is the connection (the element kind), not the points.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from code_as_monitor.core.constraints import Subgoal
from code_as_monitor.core.elements import Element, ElementKind, ElementSpec

POINT_NAME = re.compile(r"^(?P<base>.*) p(?P<i>[1-9][0-9]*)/(?P<n>[1-9][0-9]*)$")
"""How a point split from an element is named: ``"<name> p<i>/<n>"``."""


def point_name(name: str, i: int, n: int) -> str:
    """The legend name of point ``i`` (0-based) of ``n`` split from element ``name``."""
    return f"{name} p{i + 1}/{n}"


@dataclass(frozen=True)
class SplitPoint:
    """Where a point element came from: the element id and spec it was split from and its index there."""

    parent_id: int
    parent: ElementSpec
    index: int


def split_into_points(elements: list[Element], specs: dict[int, ElementSpec],
                      subgoal: Subgoal) -> tuple[list[Element], dict[int, ElementSpec], dict[int, SplitPoint]]:
    """Split every line and surface of ``elements`` (ids as in ``specs``) into point elements.

    Returns (point elements, new id -> point spec (including the missing ones' ids), new id -> :class:`SplitPoint`
    for the points that came from a line or surface). ``subgoal``'s constraints get the new ``parts`` and
    ``element_ids`` in place. An element that is missing (not in ``elements``) keeps one id, as a point spec.
    """
    built = {e.id: e for e in elements}
    new_ids: dict[int, list[int]] = {}
    out_el: list[Element] = []
    out_specs: dict[int, ElementSpec] = {}
    origin: dict[int, SplitPoint] = {}
    for old in sorted(specs):
        spec, el = specs[old], built.get(old)
        n = len(el.points) if el is not None and el.kind is not ElementKind.POINT else 1
        ids = []
        for i in range(n):
            nid = len(out_specs)
            name = point_name(spec.name, i, n) if n > 1 else spec.name
            out_specs[nid] = ElementSpec(name, spec.obj, spec.part, ElementKind.POINT)
            if el is not None:
                p = Element.point(nid, name, el.points[i], el.owner)
                p.cloud, p.object_cloud, p.support = el.cloud, el.object_cloud, el.support
                out_el.append(p)
            if n > 1:
                origin[nid] = SplitPoint(old, spec, i)
            ids.append(nid)
        new_ids[old] = ids
    for c in subgoal.constraints:
        ids = [nid for old in c.element_ids for nid in new_ids[old]]
        c.element_ids = ids
        c.parts = [out_specs[i] for i in ids]
    return out_el, out_specs, origin


__all__ = ["POINT_NAME", "SplitPoint", "point_name", "split_into_points"]
