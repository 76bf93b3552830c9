# ruff: noqa: E501  (the template bodies are generated code, kept one statement per line)
"""The stack family's check templates: each writes one ``check_<id>`` function of the monitor program.

Kept apart from :mod:`.stack` (its constraints, thresholds and recovery), which registers them. Every template reads
its constraint's element ids and thresholds (metres) and returns the source of one check: ``(ok, reason, margin)``.
"""

from __future__ import annotations

from code_as_monitor.vlm.kb.shared.codegen import Spec, check_fn, lit, num, obj_name


def attached(c: Spec) -> str:
    tip, x, tgt = c["element_ids"][:3]
    th, xn, tn = c["thresholds"], obj_name(c, 1), obj_name(c, 2)
    md, rxy, lo, hi = num(th["max_dist"]), num(th["release_xy"]), num(th["min_dz"]), num(th["max_dz"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    off = horizontal_distance(E[{x}], E[{tgt}])
    dz = centroid(E[{x}])[2] - centroid(E[{tgt}])[2]
    margin = np.max([{md} - d, np.min([{rxy} - off, dz - {lo}, {hi} - dz])])
    if d <= {md} or (off <= {rxy} and dz >= {lo} and dz <= {hi}):
        return True, {lit(xn + " held or on " + tn + " (%.3f m from the tip)")} % d, margin
    return False, {lit(xn + " dropped: %.3f m from the tip, not on " + tn)} % d, margin
"""
    return check_fn(c, body)


def still(c: Spec) -> str:
    (tgt,) = c["element_ids"][:1]
    th, tn = c["thresholds"], obj_name(c, 0)
    mx = num(th["max_disp"])
    body = f"""
    m = displacement(H[{tgt}])
    if m <= {mx}:
        return True, {lit(tn + " in place (moved %.3f m)")} % m, {mx} - m
    return False, {lit(tn + " moved %.3f m: stacking on it will topple")} % m, {mx} - m
"""
    return check_fn(c, body)


def centred(c: Spec) -> str:
    x, tgt = c["element_ids"][:2]
    th, xn, tn = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    mo = num(th["max_offset"])
    body = f"""
    off = horizontal_distance(E[{x}], E[{tgt}])
    if off <= {mo}:
        return True, {lit(xn + " centred on " + tn + " (offset %.3f m)")} % off, {mo} - off
    return False, {lit(xn + " offset %.3f m from " + tn + " (limit " + mo + "): the tower will topple")} % off, {mo} - off
"""
    return check_fn(c, body)


def resting(c: Spec) -> str:
    x, tgt = c["element_ids"][:2]
    th, xn, tn = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    lo, hi = num(th["min_dz"]), num(th["max_dz"])
    body = f"""
    dz = centroid(E[{x}])[2] - centroid(E[{tgt}])[2]
    margin = np.min([dz - {lo}, {hi} - dz])
    if dz >= {lo} and dz <= {hi}:
        return True, {lit(xn + " rests on " + tn + " (dz %.3f m)")} % dz, margin
    return False, {lit(xn + " not resting on " + tn + ": dz %.3f m, not " + lo + " to " + hi)} % dz, margin
"""
    return check_fn(c, body)


def released(c: Spec) -> str:
    """Released: the tip is ``release_dist`` from the block and has moved ``min_gain`` further from it than it
    came in the history (a block the cup took at the edge of a side face hangs 4.4 cm from the tip while on it;
    a block never near the cup is released once the tip moved away from it)."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 1)
    rd, gain = num(th["release_dist"]), num(th["min_gain"])
    body = f"""
    d = distance(E[{tip}], E[{x}])
    gap = d - np.min(np.linalg.norm(H[{x}].mean(axis=1) - H[{tip}].mean(axis=1), axis=1))
    margin = np.min([d - {rd}, gap - {gain}])
    if d >= {rd} and gap >= {gain}:
        return True, {lit(xn + " released (tip %.3f m away)")} % d, margin
    return False, {lit(xn + " still held (tip %.3f m away, %.3f m further than it came)")} % (d, gap), margin
"""
    return check_fn(c, body)


def taken(c: Spec) -> str:
    """Parts: [tip, the block to pick, other blocks...]. True while the block to pick is held or no other block is
    on the tip (see the ``taken`` thresholds)."""
    tip, x = c["element_ids"][:2]
    th, xn = c["thresholds"], obj_name(c, 1)
    md, mr, cd, lag = num(th["max_dist"]), num(th["min_rise"]), num(th["carried_dist"]), num(th["max_lag"])
    body = f"""
    travel = centroid(E[{tip}]) - centroid(H[{tip}][0])
    moved = np.linalg.norm(travel)
    d = distance(E[{tip}], centroid(E[{x}]))
    if d <= {md} and centroid(E[{x}])[2] - centroid(H[{x}][0])[2] >= {mr}:
        return True, {lit(xn + " held (%.3f m from the tip)")} % d, {md} - d
    gaps = []
"""
    for i, k in enumerate(c["element_ids"][2:]):
        kn = obj_name(c, i + 2)
        body += f"""    dk = distance(E[{tip}], centroid(E[{k}]))
    rk = centroid(E[{k}])[2] - centroid(H[{k}][0])[2]
    lk = np.linalg.norm(centroid(E[{k}]) - centroid(H[{k}][0]) - travel)
    if (dk <= {md} and rk >= {mr}) or (dk <= {cd} and moved >= {mr} and lk <= {lag} * moved):
        return False, {lit(kn + " is on the tip instead of " + xn + " (%.3f m from it, risen %.3f m)")} % (dk, rk), dk - {cd}
    gaps.append(dk - {md})
"""
    body += f"""    return True, {lit("no other block on the tip")}, np.min(gaps)
"""
    return check_fn(c, body)


def plumb(c: Spec) -> str:
    up, lo_id = c["element_ids"][:2]
    th, un, ln = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    mo = num(th["max_offset"])
    body = f"""
    off = horizontal_distance(E[{up}], E[{lo_id}])
    if off <= {mo}:
        return True, {lit(un + " centred on " + ln + " (offset %.3f m)")} % off, {mo} - off
    return False, {lit(un + " knocked %.3f m off " + ln + " (limit " + mo + "): stacking on it will topple")} % off, {mo} - off
"""
    return check_fn(c, body)


def tower(c: Spec) -> str:
    up, lo_id = c["element_ids"][:2]
    th, un, ln = c["thresholds"], obj_name(c, 0), obj_name(c, 1)
    mo, lo, hi = num(th["max_offset"]), num(th["min_dz"]), num(th["max_dz"])
    body = f"""
    off = horizontal_distance(E[{up}], E[{lo_id}])
    dz = centroid(E[{up}])[2] - centroid(E[{lo_id}])[2]
    margin = np.min([{mo} - off, dz - {lo}, {hi} - dz])
    if off <= {mo} and dz >= {lo} and dz <= {hi}:
        return True, {lit(un + " on " + ln + " (offset %.3f m)")} % off, margin
    return False, {lit(un + " no longer on " + ln + " (offset %.3f m, dz %.3f m): the tower collapsed")} % (off, dz), margin
"""
    return check_fn(c, body)
