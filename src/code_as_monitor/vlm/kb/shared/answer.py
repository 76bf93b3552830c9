"""Building blocks of the generator's JSON answer, shared by every task family.

A family's constraint builders return constraint dicts in the generator's answer format (see
:mod:`code_as_monitor.vlm.schemas`); a constraint id starts with its template key (``held_``, ``attached_``,
...), which :mod:`code_as_monitor.vlm.kb.coder` uses to pick the template that writes its check.
"""

from __future__ import annotations

from typing import Any

TIP = {"name": "suction cup tip", "obj": "robot", "part": "tip", "kind": "point"}
"""The suction cup's tip, from forward kinematics (never segmented)."""


def nice(obj: str) -> str:
    """Human form of an object name: ``green_block`` -> ``the green block``."""
    return "the " + obj.replace("_", " ")


def whole(obj: str) -> dict[str, str]:
    """A whole object abstracted as one point (its centre)."""
    return {"name": obj.replace("_", " "), "obj": obj, "part": "", "kind": "point"}


def constraint(cid: str, text: str, phase: str, proactive: bool, thr: dict[str, float],
               parts: list[dict]) -> dict[str, Any]:
    """One constraint of the answer: ``phase`` "during" or "upon", ``parts`` element specs (obj, part, kind)."""
    return {"id": cid, "text": text, "phase": phase, "proactive": proactive, "thresholds": thr, "parts": parts}


def answer(text: str, skill: str, args: dict[str, Any], cons: list[dict[str, Any]], why: str) -> dict[str, Any]:
    """The generator's JSON answer for one subgoal (the format a VLM is asked for)."""
    return {"subgoal": text, "done": False, "action": {"skill": skill, "args": args}, "constraints": cons,
            "reasoning": why}


def done(why: str) -> dict[str, Any]:
    """The answer that ends the task."""
    return {"subgoal": "task complete", "done": True, "action": None, "constraints": [], "reasoning": why}
