"""Classifying the monitor's feedback on the previous subgoal into a recovery category.

The feedback is free text: "success", or the reason string a violated check returned (possibly
prefixed by the agent, e.g. ``"failed: attached_green_block: green_block dropped ..."``). The kb
recognises its own reason phrasing and common paraphrases by keywords, checked in this order:

=========== ===================================================== =========================================
category    keywords                                              recovery (stacking)
=========== ===================================================== =========================================
taken       instead of (another object was taken: "holds Y        put Y down on free table, then pick the
            instead of X")                                        block again
collapse    collapsed, moved, disturbed, no longer on, fell off,   restart from the lowest tower level named
            knocked                                               in the feedback (at least level 1)
offset      offset, off-centre/center, misaligned, not centred    pick the misplaced block again, re-place it
still_held  still held, not released                              repeat the placement
dropped     dropped, detached, not attached, not held, fell from, pick the block again
            not resting on, lost
overshoot   more than, too many, above the upper                  (sweeping) nothing to undo: stop
other       anything else that is not a success                   repeat the previous subgoal
=========== ===================================================== =========================================

The gripper families recover by the failed constraint's template key instead (:func:`failed_kind`): the
agent's feedback is ``"failure: <constraint id>: <reason>"`` and the id starts with the key.
"""

from __future__ import annotations

import re

from code_as_monitor.vlm.schemas import SUCCESS_FEEDBACK

__all__ = ["CATEGORIES", "SUCCESS_FEEDBACK", "classify", "failed_kind", "mentioned"]

_SUCCESS_RE = re.compile(r"^\s*(success|succeeded|ok|done|completed?|subgoal (succeeded|completed?))\b", re.I)

CATEGORIES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("taken", ("instead of",)),
    ("collapse", ("collapsed", "collapse", "moved", "disturbed", "no longer on", "fell off", "knocked")),
    ("offset", ("offset", "off-centre", "off-center", "off centre", "off center", "misaligned", "not centred")),
    ("still_held", ("still held", "not released")),
    ("dropped", ("dropped", "detached", "not attached", "not held", "fell from", "not resting on", "lost")),
    ("overshoot", ("more than", "too many", "above the upper")),
)


def classify(feedback: str | None) -> str:
    """``"success"``, one of the failure categories above, or ``"other"``."""
    if feedback is None or not feedback.strip():
        return "success"
    s = feedback.lower()
    for name, words in CATEGORIES:
        if any(w in s for w in words):
            return name
    if _SUCCESS_RE.match(s):
        return "success"
    return "other"


def mentioned(feedback: str | None, names: tuple[str, ...] | list[str]) -> list[str]:
    """The names among ``names`` that appear in ``feedback``, in order of first appearance."""
    if not feedback:
        return []
    s = feedback.lower()
    hits = []
    for n in names:
        for form in (n.lower(), n.lower().replace("_", " ")):
            m = re.search(rf"\b{re.escape(form)}\b", s)
            if m:
                hits.append((m.start(), n))
                break
    return [n for _, n in sorted(hits)]


_PREFIX_RE = re.compile(r"(?:failure|failed)\s*:\s*([a-z]+)_", re.I)
_KIND_KEYWORDS = (
    ("gripped", ("dropped", "no longer held", "not held")),
    ("carried", ("not inside and dropped",)),
    ("steady", ("moved", "close on nothing")),
    ("upright", ("upright", "vertical", "tilted")),
    ("over", ("not above the opening", "miss")),
    ("inside", ("not inside",)),
    ("freed", ("still held",)),
)


def failed_kind(feedback: str | None) -> str:
    """``"success"``, the failed constraint's template key (``gripped``, ``over``, ...) or ``"other"``.

    The key is the id prefix after ``failure:``; free text without one falls back to keywords."""
    if classify(feedback) == "success":
        return "success"
    m = _PREFIX_RE.search(feedback or "")
    if m:
        return m.group(1).lower()
    s = (feedback or "").lower()
    for kind, words in _KIND_KEYWORDS:
        if any(w in s for w in words):
            return kind
    return "other"
