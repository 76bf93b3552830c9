"""The skills a policy offers, as the constraint generator is told about them.

These are the simulator's skills (see ``docs/architecture.md``); a simulated episode offers the planner only
those its robot's end-effector can execute (:func:`skill_table` of the policy's ``skills``). A real robot
passes its own table to :class:`~code_as_monitor.planning.generator.ConstraintGenerator`.
"""

from __future__ import annotations

from collections.abc import Iterable

from code_as_monitor.core.errors import ConfigError

DEFAULT_SKILLS: dict[str, str] = {
    "pick": "{obj}: descend onto the object, suction on, lift",
    "place_on": '{obj, target (name or "table"), xy optional}: carry the held object above the target, lower, '
                "release, retreat",
    "push_into_region": "{region}: spatula pushes of the blocks outside the region towards it (never stops itself)",
    "close_shape": "{rope, shape}: moves rope beads towards the shape's opening (never stops itself)",
    "grasp": "{obj, part optional}: close the gripper across the object's long axis at the part, lift",
    "reorient": '{obj, axis: "vertical"}: tilt the held object until its long axis points down, tip first',
    "insert": "{obj, target}: lower the held object's lower end into the target's opening, release, retreat",
    "stow": "{obj, target}: lower the held upright object (a book) into the target's slot, release, retreat",
    "pull": "{obj, distance (m)}: pull the grasped handle out along the drawer's axis, release, retreat",
    "transport": "{obj, target}: carry the held teapot at its tilt until its spout is above the target (a cup)",
    "pour": "{obj, target}: tilt the held teapot past the pour angle, spout end down to just above the target",
    "drain": "{obj, target}: hold the tilted teapot still a few seconds while the tea runs out",
    "level": "{obj}: turn the wrist until the held object stands level (top horizontal)",
    "set_down": "{obj}: put the held object on a free spot of the table away from the cup, release, lift",
    "put_in": "{obj, target}: lower the held object into the open tray of the target drawer, release, retreat",
    "screw": "{obj, turns}: turn the grasped bulb clockwise into its socket (re-grasping between strokes), "
             "release, retreat",
    "turn": "{obj, part: handle, angle (degrees)}: turn the grasped tap handle about its hinge, release, retreat",
    "drag": "{obj, target, goal}: with the held stick, pull the target object onto the goal, put the stick "
            "down, retreat",
    "sweep": "{obj, target}: push the loose pieces into the target (a dustpan) with the held broom's head, lift, "
             "keep holding",
}
"""Skill name -> its argument keys (values: object names unless said) and what it does, in one short line."""

RUN_TO_END: tuple[str, ...] = ("pour",)
"""Skills of :data:`DEFAULT_SKILLS` that run to their end even when their subgoal's ``upon`` checks already hold
(every other skill a monitor may halt as soon as they do, which is how the skills that never stop themselves end).
The pour: its tilt and its aim over the cup are its goal, and a pour halted when the pot was first "tipped past the
pour angle" left the tea jammed in the spout trough (pour-tea seed 11, undisturbed: halted at a 58.6-degree tilt of
the skill's 70, 9 of 30 particles in the cup, where the open loop pours 30; pour-tea (b) seed 0: 13 of 30); run to
its end, both pour 30 of 30. A real robot's caller names its own (:attr:`AgentConfig.run_to_end
<code_as_monitor.agent.config.AgentConfig.run_to_end>`)."""


def skills_markdown(skills: dict[str, str]) -> str:
    """The skills as a Markdown bullet list for the prompt."""
    return "\n".join(f"- `{name}` {doc}" for name, doc in skills.items())


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
