"""kb rules for ``stow-book`` (line level): constraint builders and the stateless next-subgoal rule.

Family ``book`` ("put the book upright into the bookshelf"): ``grasp`` the book by its cover ->
``reorient`` it spine-vertical -> ``stow`` it into the shelf slot -> done. Elements: the gripper's grasp
point (``robot/tip``, point), the book's centre (``book/cover``, point), its spine (``book/spine``, a
LINE: its two ends; ``direction``/``angle_to_vertical`` give its tilt), the shelf slot
(``bookshelf/slot``, a SURFACE: the rim's corners; its centroid is the slot's centre).

Recovery by the failed constraint's id prefix (``"failure: <id>: <reason>"``):

================================================ ============================================
failed                                           next subgoal
================================================ ============================================
steady/aligned/grasped/raised (moved, turned,    grasp again (where it lies now)
not held), gripped/conveyed (dropped),
shelved/standing (not standing in the slot)
upright/poised (tilted in the gripper)            reorient again
aimed (low beside the slot)                       reorient (lifts it upright), then stow
freed (still held)                                stow again
================================================ ============================================
"""

from __future__ import annotations

from typing import Any

from code_as_monitor.vlm.kb.grip import GRIP_TIP, in_gripper, part_spec, still_gripped
from code_as_monitor.vlm.kb.skills import _c, answer, nice
from code_as_monitor.vlm.kb.thresholds import thresholds


def _cover(obj: str) -> dict[str, str]:
    return part_spec(obj, "cover", "point", "centre")


def _spine(obj: str) -> dict[str, str]:
    return part_spec(obj, "spine", "line", "spine")


def _slot(obj: str) -> dict[str, str]:
    return part_spec(obj, "slot", "surface", "slot")


def grasp(obj: str) -> list[dict[str, Any]]:
    """``grasp``: during (proactive) the book lies as it did (same slope and direction); upon, gripped, and
    risen since the grasp began.

    No ``steady`` (displacement) check: a book is turned about its centre under the gripper, which stays
    within the steady check's grasp-point radius, so after a halt there that check could never fail on
    the restart state (path coverage rejects it); ``aligned`` is the book's version."""
    al, li, ra = thresholds("aligned"), thresholds("lifted_book"), thresholds("raised_book")
    return [
        _c(f"aligned_{obj}", f"the spine of {nice(obj)} lies as it did (slope within 20, direction within 15 degrees) "
           f"while the gripper approaches; a turned book is gripped skewed and cannot be stood upright", "during",
           True, al, [_spine(obj)]),
        in_gripper(obj, _cover(obj), li)[0],
        _c(f"raised_{obj}", f"{nice(obj)} is picked up: its centre at least {ra['min_rise'] * 100:.0f} cm above "
           f"where it was when the grasp began", "upon", False, ra, [_cover(obj)]),
    ]


def reorient(obj: str) -> list[dict[str, Any]]:
    """``reorient``: during, still gripped; upon, the spine (a line) within 12 degrees of vertical."""
    gr, up = thresholds("gripped_book"), thresholds("upright_book")
    return [
        still_gripped(obj, _cover(obj), gr),
        _c(f"upright_{obj}", f"the spine of {nice(obj)} is upright: within 12 degrees of vertical", "upon", False, up,
           [_spine(obj)]),
    ]


def stow(obj: str, target: str) -> list[dict[str, Any]]:
    """``stow``: during, gripped, spine near vertical, centred when low; upon, in the slot, released, standing."""
    cv, po, ai = thresholds("conveyed"), thresholds("poised"), thresholds("aimed")
    sh, fr, sd = thresholds("shelved"), thresholds("freed_book"), thresholds("standing")
    return [
        _c(f"conveyed_{obj}", f"{nice(obj)} stays in the gripper (within {cv['max_dist'] * 100:.0f} cm of the grasp "
           f"point) until it stands in the slot of {nice(target)}", "during", False, cv,
           [GRIP_TIP, _cover(obj), _spine(obj), _slot(target)]),
        _c(f"poised_{obj}", f"while held above the slot, the spine of {nice(obj)} stays within 25 degrees of "
           f"vertical", "during", False, po, [GRIP_TIP, _cover(obj), _spine(obj), _slot(target)]),
        _c(f"aimed_{target}", f"{nice(obj)} is centred over the slot of {nice(target)} (within "
           f"{ai['max_offset'] * 100:.0f} cm) whenever its lower end is less than {ai['approach'] * 100:.0f} cm "
           f"above the rim", "during", True, ai, [_cover(obj), _spine(obj), _slot(target)]),
        _c(f"shelved_{target}", f"the lower end of {nice(obj)} is in the slot of {nice(target)}, at least "
           f"{sh['min_depth'] * 100:.0f} cm below the rim", "upon", False, sh,
           [_cover(obj), _spine(obj), _slot(target)]),
        _c(f"freed_{obj}", f"{nice(obj)} is released: the grasp point at least {fr['release_dist'] * 100:.0f} cm "
           f"from its centre", "upon", False, fr, [GRIP_TIP, _cover(obj)]),
        _c(f"standing_{obj}", f"{nice(obj)} stands: its spine within 20 degrees of vertical", "upon", False, sd,
           [_spine(obj)]),
    ]


REGRASP = ("steady", "aligned", "grasped", "lifted", "raised", "gripped", "conveyed", "shelved", "standing")


def next_book(book: str, shelf: str, previous: dict[str, Any] | None, kind: str) -> dict[str, Any]:
    """The next subgoal for the book family; ``kind`` is the failed constraint's key (or ``success``)."""
    g = answer(f"grasp {nice(book)} by its cover", "grasp", {"obj": book, "part": "cover"}, grasp(book), "")
    r = answer(f"turn {nice(book)} upright, spine vertical", "reorient", {"obj": book, "axis": "vertical"},
                reorient(book), "")
    s = answer(f"stow {nice(book)} upright in {nice(shelf)}", "stow", {"obj": book, "target": shelf},
                stow(book, shelf), "")
    done = {"subgoal": "task complete", "done": True, "action": None, "constraints": [],
            "reasoning": "the book stands in the shelf"}
    skill = ((previous or {}).get("action") or {}).get("skill")
    if not previous or skill not in ("grasp", "reorient", "stow"):
        if previous and previous.get("done"):
            return done
        g["reasoning"] = "the book lies on the table: grasp it first, then stand it upright and stow it"
        return g
    if kind == "success":
        if skill == "grasp":
            r["reasoning"] = "the book is held; it goes into the slot spine-vertical"
            return r
        if skill == "reorient":
            s["reasoning"] = "the book is upright; bring it above the slot and lower it in"
            return s
        return done
    if kind in REGRASP or (skill == "grasp" and kind == "other"):
        g["reasoning"] = (f"the book is not held straight or not standing in the shelf ({kind}); grasp it again "
                          f"where it is now")
        return g
    if kind in ("upright", "poised") or (skill == "reorient" and kind == "other"):
        r["reasoning"] = "the book's spine is tilted in the gripper; turn it upright again"
        return r
    if kind == "aimed":
        r["reasoning"] = "the book is low beside the slot: lift it upright first, then stow it where the slot is now"
        return r
    s["reasoning"] = f"the stow did not finish ({kind}); lift the book and stow it again"
    return s
