"""A pronoun with nothing before it to stand for.

"Put the cube into the drawer after opening it" is read in the order things happen ("open it, then put the cube
into the drawer"), and "it" then comes before every noun: it stands for the one thing named after it that its verb
can take (a drawer opens; a cube does not), or the one such thing that is a verb's object there. Before, such
instructions were refused ("has no use for 'it'"). Where two things fit, it stays unresolved and is refused.
"Pick it up" / "pick the pen up" / "set it down on ...": the particle after the object is part of the verb (the
families refused "cannot honour 'up'" / "'down'").
"""

from __future__ import annotations

import pytest

from code_as_monitor.core.errors import InstructionError
from code_as_monitor.planning import ConstraintGenerator
from code_as_monitor.vlm.grammar.parse import parse
from code_as_monitor.vlm.kb import KBBackend
from code_as_monitor.vlm.kb.planner import infer_objects, understand


def _plan(text: str, objects: list[str], steps: int = 6) -> list:
    gen, prev, out = ConstraintGenerator(KBBackend()), None, []
    for fb in [None] + ["success"] * steps:
        prev = gen.next_subgoal(text, {}, objects, prev, fb)
        out.append((prev.text, prev.action, [(c.id, c.thresholds) for c in prev.constraints], prev.done))
        if prev.done:
            break
    return out


@pytest.mark.parametrize(("text", "same_as"), [
    ("put the cube into the drawer after opening it", "open the drawer and put the block in it"),
    ("put the block in the drawer after you open it", "open the drawer and put the block in it"),
    ("after you open it, put the block in the drawer", "open the drawer and put the block in it"),
    ("after grasping it, put the red block on the green block", "put the red block on the green block"),
    ("after picking it up, put the pen into the holder", "put the pen into the pen holder"),
    ("pick the pen up and put it in the holder", "put the pen into the pen holder"),  # the particle after its object
    ("lift the red block and set it down on the green block", "put the red block on the green block"),
    ("set down the green block on the red block", "put the green block on the red block"),
])
def test_a_pronoun_before_every_noun_stands_for_what_its_verb_can_take(text: str, same_as: str) -> None:
    objects = infer_objects(same_as)
    assert _plan(text, objects) == _plan(same_as, objects)


def test_the_drawer_not_the_cube_is_what_opens() -> None:
    ins = parse("open it then put the cube into the drawer")
    it = next(p for p in ins.phrases if p.pronoun)
    assert ins.resolve(it.index).head == "drawer"


@pytest.mark.parametrize(("text", "objects"), [
    ("put the block on the green block after picking it up", ["red_block", "green_block", "blue_block", "table"]),
    ("open it", ["drawer_cabinet", "block", "table"]),
])
def test_a_pronoun_that_could_stand_for_two_things_or_none_is_refused(text: str, objects: list[str]) -> None:
    with pytest.raises(InstructionError):
        understand(text, objects)
