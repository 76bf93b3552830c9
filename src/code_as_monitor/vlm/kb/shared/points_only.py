"""The kb coder's point-only path: checks over unconnected 3-D points (the ablation "CP off").

When the painter hands over no lines or surfaces, each of them arrives as its points, each a point element of its
own, named ``"<name> p<i>/<n>"`` in the legend (:mod:`code_as_monitor.painter.point_elements`; the kb reads only
the request, as a model would read the numbered points and their legend). The kb groups a constraint's
consecutive points of one object part named ``p1/n`` .. ``pn/n`` back into the part they come from (two points: a
line's ends; three or more: a surface's corners), writes the family's template for the part kinds it now knows,
and makes the program *recombine the points itself*: each recombined part becomes a local array built from the
point elements at the top of the check (``P<id> = np.concatenate([E[a], E[b]], axis=0)``, and its history
``Q<id> = np.concatenate([H[a], H[b]], axis=1)``), so the check reads point elements only. The program then goes
through the same parsing, validation and path coverage as any other.
"""

from __future__ import annotations

import re
from typing import Any

from code_as_monitor.core.errors import VLMError

Spec = dict[str, Any]
_NAME = re.compile(r"^(?P<base>.*) p(?P<i>[1-9][0-9]*)/(?P<n>[1-9][0-9]*)$")
_KIND_BY_COUNT = {1: "point", 2: "line"}


def is_points_only(legend: dict[int, dict[str, str]]) -> bool:
    """True when every element of the request's legend is a point and some are points split from a part."""
    return bool(legend) and all(p["kind"] == "point" for p in legend.values()) \
        and any(_NAME.match(p["name"]) for p in legend.values())


def group_points(ids: list[int], legend: dict[int, dict[str, str]]) -> list[list[int]]:
    """``ids`` grouped into the parts they come from: a run ``p1/n`` .. ``pn/n`` of one object part is one group;
    any other point is a group of its own. VLMError naming a broken run (a point ``pi/n`` out of order)."""
    groups: list[list[int]] = []
    k = 0
    while k < len(ids):
        m = _NAME.match(legend[ids[k]]["name"])
        if m is None or int(m["i"]) != 1:
            if m is not None:
                raise VLMError(f"kb: element {ids[k]} ({legend[ids[k]]['name']!r}) is not the first point of its part")
            groups.append([ids[k]])
            k += 1
            continue
        n, run = int(m["n"]), ids[k:k + int(m["n"])]
        want = [f"{m['base']} p{i}/{n}" for i in range(1, n + 1)]
        owner = (legend[ids[k]]["obj"], legend[ids[k]]["part"])
        if [legend[i]["name"] for i in run] != want or any((legend[i]["obj"], legend[i]["part"]) != owner for i in run):
            raise VLMError(f"kb: the points of {m['base']!r} are not listed together in order ({run})")
        groups.append(run)
        k += n
    return groups


def grouped_spec(c: Spec, groups: list[list[int]], legend: dict[int, dict[str, str]]) -> Spec:
    """Constraint ``c`` as if each group were one element (its first point's id) of the kind its size gives."""
    parts = []
    for g in groups:
        p = dict(legend[g[0]])
        m = _NAME.match(p["name"])
        p["name"] = m["base"] if m is not None else p["name"]
        p["kind"] = _KIND_BY_COUNT.get(len(g), "surface")
        parts.append(p)
    return {**c, "element_ids": [g[0] for g in groups], "parts": parts}


def recombine(source: str, groups: list[list[int]]) -> str:
    """``source`` (one ``def check_...`` written over grouped ids) rewritten to read only the point elements: each
    group of several points is assembled at the top of the function into ``P<id>`` (and ``Q<id>`` for its
    history) and every ``E[<id>]`` / ``H[<id>]`` of the group's id is replaced by them."""
    head, _, body = source.partition("\n")
    pre = []
    for g in groups:
        if len(g) < 2:
            continue
        v = g[0]
        e_pat, h_pat = re.compile(rf"\bE\[{v}\]"), re.compile(rf"\bH\[{v}\]")
        if e_pat.search(body):
            body = e_pat.sub(f"P{v}", body)
            pre.append(f"    P{v} = np.concatenate([{', '.join(f'E[{i}]' for i in g)}], axis=0)")
        if h_pat.search(body):
            body = h_pat.sub(f"Q{v}", body)
            pre.append(f"    Q{v} = np.concatenate([{', '.join(f'H[{i}]' for i in g)}], axis=1)")
    return "\n".join([head, *pre, body]) if pre else source


__all__ = ["group_points", "grouped_spec", "is_points_only", "recombine"]
