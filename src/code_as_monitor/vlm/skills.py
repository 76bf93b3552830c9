"""The skills a policy offers, as the constraint generator is told about them.

These are the simulator's skills (see ``docs/architecture.md``); a simulated episode offers the planner only
those its robot's end-effector can execute (:func:`skill_table` of the policy's ``skills``). A real robot
passes its own table to :class:`~code_as_monitor.planning.generator.ConstraintGenerator`.
"""

from __future__ import annotations

from collections.abc import Iterable

from code_as_monitor.core.errors import ConfigError

DEFAULT_SKILLS: dict[str, str] = {
    "pick": 'args {"obj": name}: approach above the object, descend to contact, suction on, lift to carry height',
    "place_on": (
        'args {"obj": name, "target": name or "table", "xy": [x, y] optional}: carry the held object above '
        "the target, descend, release, retreat up"
    ),
    "push_into_region": (
        'args {"region": name}: repeated spatula pushes of the blocks outside the region towards it, until '
        "none is left (it never stops by itself)"
    ),
    "close_shape": (
        'args {"rope": name, "shape": name}: repeated adjustments of rope beads towards the opening of the '
        "shape (it never stops by itself)"
    ),
    "grasp": (
        'args {"obj": name, "part": part optional}: open the gripper, descend over the part with the jaws '
        "across the object's long axis, close, lift to carry height"
    ),
    "reorient": (
        'args {"obj": name, "axis": "vertical"}: tilt the held object until its long axis points straight '
        "down, tip first"
    ),
    "insert": (
        'args {"obj": name, "target": name}: carry the held object\'s lower end above the target\'s opening, '
        "lower it in, open the gripper, retreat"
    ),
    "stow": (
        'args {"obj": name, "target": name}: carry the held upright object (a book) above the target\'s slot, '
        "lower it in, open the gripper, retreat"
    ),
    "pull": (
        'args {"obj": name, "distance": metres}: pull the grasped handle straight out along the drawer\'s axis by '
        "the distance, open the gripper, retreat"
    ),
    "transport": (
        'args {"obj": name, "target": name}: carry the held object (a teapot) at its current tilt until its spout '
        "is above the target (a cup)"
    ),
    "pour": (
        'args {"obj": name, "target": name}: tilt the held teapot forward past the pour angle, its spout\'s end '
        "moving down to just above the target's opening"
    ),
    "drain": (
        'args {"obj": name, "target": name}: hold the tilted teapot still for a few seconds while the tea runs out'
    ),
    "level": 'args {"obj": name}: turn the wrist until the held object stands level (its top horizontal)',
    "set_down": (
        'args {"obj": name}: carry the held object to a free spot of the table away from the cup, lower it until '
        "it almost touches, open the gripper, lift"
    ),
    "put_in": (
        'args {"obj": name, "target": name}: carry the held object above the open part of the target drawer\'s '
        "tray, lower it to just above the tray's floor, open the gripper, retreat"
    ),
    "screw": (
        'args {"obj": name, "turns": number}: turn the grasped bulb clockwise into its socket in a few strokes '
        "(re-grasping between them), open the gripper, retreat"
    ),
    "turn": (
        'args {"obj": name, "part": handle, "angle": degrees}: turn the grasped tap handle about its hinge by the '
        "angle, open the gripper, retreat"
    ),
    "drag": (
        'args {"obj": name, "target": name, "goal": name}: lower the held stick on the table beyond the target '
        "object and pull it until the object is on the goal, put the stick down, retreat"
    ),
    "sweep": (
        'args {"obj": name, "target": name}: lower the held broom\'s head behind the loose pieces and push them '
        "into the target (a dustpan), lift, keep holding the broom"
    ),
}
"""Skill name -> one-line description of its arguments and behaviour."""


def skills_markdown(skills: dict[str, str]) -> str:
    """The skills as a Markdown bullet list for the prompt."""
    return "\n".join(f"- `{name}`: {doc}" for name, doc in skills.items())


def skill_table(names: Iterable[str] | None) -> dict[str, str]:
    """The entries of :data:`DEFAULT_SKILLS` for ``names`` (the skills a policy offers), in their order; all
    of them when ``names`` is None. ConfigError naming an unknown skill."""
    if names is None:
        return dict(DEFAULT_SKILLS)
    table = {}
    for n in names:
        if n not in DEFAULT_SKILLS:
            raise ConfigError(f"unknown skill {n!r}; known: {', '.join(DEFAULT_SKILLS)}")
        table[n] = DEFAULT_SKILLS[n]
    if not table:
        raise ConfigError("a policy must offer at least one skill")
    return table
