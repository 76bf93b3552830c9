"""Checks kept per constraint and renumbered for a later subgoal (planning.check_reuse, MonitorCoder)."""

from __future__ import annotations

import ast

import numpy as np
import pytest

from code_as_monitor.core import Action, Constraint, Element, ElementSpec, Subgoal
from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.sandbox import Sandbox
from code_as_monitor.planning import MonitorCoder, basic_check, legend_specs
from code_as_monitor.planning.check_reuse import REUSED_HEADER, combine, renumber, split_checks
from code_as_monitor.vlm.backend import VLMResponse
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.parsing import extract_request

TIP = ElementSpec("tip", "robot", "tip", "point")
RED = ElementSpec("red", "red_block", "", "point")
GREEN = ElementSpec("green", "green_block", "", "point")
BLUE = ElementSpec("blue", "blue_block", "", "point")

TOWER = """def check_tower(E, H, t):
    off = horizontal_distance(E[1], E[2])
    rise = centroid(E[1])[2] - centroid(H[1][0])[2]
    if off <= 0.025 and H.t[-1] >= 0.0:
        return True, 'on (%.3f m, rose %.3f)' % (off, rise), 0.025 - off
    return False, 'off %.3f m' % off, 0.025 - off
"""


def test_renumber_maps_element_subscripts_and_keeps_the_rest():
    out = renumber(TOWER, (1, 2), [3, 0])
    assert out is not None
    tree = ast.parse(out)
    subs = sorted({(n.value.id, n.slice.value) for n in ast.walk(tree)
                   if isinstance(n, ast.Subscript) and isinstance(n.value, ast.Name) and n.value.id in "EH"})
    assert subs == [("E", 0), ("E", 3), ("H", 3)]  # E[1] -> E[3], E[2] -> E[0], H[1] -> H[3]
    assert "H.t[-1]" in out and "0.025" in out and "'off %.3f m' % off" in out
    assert renumber(out, (3, 0), [1, 2]) is not None
    assert ast.dump(ast.parse(renumber(out, (3, 0), [1, 2]))) == ast.dump(ast.parse(TOWER))  # and back


@pytest.mark.parametrize("body", [
    "    i = 1\n    return True, 'x %.3f' % E[i][0][0], 1.0\n",      # an index computed at run time
    "    return True, 'x %d' % len(E), 1.0\n",                       # E itself
    "    ids = [i for i in [1, 2] if i in E]\n    return True, 'x', 1.0\n",  # a monotone set
    "    return True, 'x %.3f' % E[7][0][0], 1.0\n",                 # an id the constraint does not read
    "    E[1] = 0\n    return True, 'x', 1.0\n",                     # a store
])
def test_renumber_refuses_what_it_cannot_map_exactly(body):
    assert renumber("def check_a(E, H, t):\n" + body, (1, 2), [0, 1]) is None


def test_renumber_refuses_renamed_arguments_and_mismatched_ids():
    assert renumber("def check_a(P, Q, t):\n    return True, 'x', P[1]\n", (1,), [0]) is None
    assert renumber(TOWER, (1, 2), [0]) is None
    assert renumber(TOWER, (1, 1), [0, 2]) is None  # one old id, two new ones


def test_split_checks_leaves_functions_that_read_their_programs_helpers():
    src = ("LIMIT = 0.02\n\ndef helper(a):\n    return a\n\n"
           "def check_a(E, H, t):\n    return True, 'x', LIMIT\n\n"
           "def check_b(E, H, t):\n    return True, 'x', helper(1.0)\n\n"
           "def check_c(E, H, t):\n    d = distance(E[0], E[1])\n    return True, 'x %.3f' % d, 1.0\n")
    assert list(split_checks(src)) == ["check_c"]
    assert split_checks("def check_a(E, H, t)\n") == {}


def test_combine_keeps_the_models_own_definition():
    asked = "# by the model\n\ndef check_a(E, H, t):\n    return True, 'new', 1.0\n"
    reused = {"check_a": "def check_a(E, H, t):\n    return True, 'old', 1.0",
              "check_b": "def check_b(E, H, t):\n    return True, 'b', 1.0"}
    out = combine(asked, reused)
    names = [n.name for n in ast.parse(out).body if isinstance(n, ast.FunctionDef)]
    assert names == ["check_a", "check_b"] and "'new'" in out and "'old'" not in out and REUSED_HEADER in out
    assert combine(None, {"check_b": reused["check_b"]}).startswith(REUSED_HEADER)


class Scripted:
    def __init__(self, *texts: str) -> None:
        self.texts = list(texts)
        self.calls: list[list[Message]] = []

    def complete(self, messages: list[Message], *, purpose: str, schema: dict | None = None) -> VLMResponse:
        self.calls.append(messages)
        return VLMResponse(self.texts.pop(0), 10, 5, "scripted")


def _elements(sg: Subgoal) -> list[Element]:
    return [Element(i, s.name, s.kind, np.full((1, 3), float(i)), (s.obj, s.part))
            for i, s in enumerate(legend_specs(sg))]


def _tower(th: float = 0.025) -> Constraint:
    return Constraint("tower", "green still on red", "during", [GREEN, RED], thresholds={"max_offset": th})


def _pick_blue(tower: Constraint | None = None) -> Subgoal:
    held = Constraint("held", "blue held", "upon", [TIP, BLUE])
    return Subgoal("pick up the blue block", [held, tower or _tower()], Action("pick", {"obj": "blue_block"}))


def _place_blue(tower: Constraint | None = None) -> Subgoal:
    rest = Constraint("rests", "blue rests on green", "upon", [BLUE, GREEN])
    return Subgoal("place blue on green", [rest, tower or _tower()],
                   Action("place_on", {"obj": "blue_block", "target": "green_block"}))


HELD = "def check_held(E, H, t):\n    d = distance(E[0], E[1])\n    return True, 'held %.3f' % d, 0.04 - d\n"
TOWER_AT = ("def check_tower(E, H, t):\n    off = horizontal_distance(E[{g}], E[{r}])\n"
            "    return True, 'on %.3f' % off, 0.025 - off\n")
RESTS = "def check_rests(E, H, t):\n    dz = E[0][0][2] - E[1][0][2]\n    return True, 'dz %.3f' % dz, dz\n"


def test_a_later_subgoal_asks_only_for_its_new_constraints():
    pick, place = _pick_blue(), _place_blue()
    # pick: tip 0, blue 1, green 2, red 3; place: blue 0, green 1, red 2
    be = Scripted(HELD + "\n" + TOWER_AT.format(g=2, r=3), RESTS)
    coder = MonitorCoder(be)
    checked: list[str] = []

    def check(source: str) -> None:
        basic_check([c.id for c in current.constraints])(source)
        checked.append(source)

    current = pick
    coder.write_program(pick, _elements(pick), {}, check)
    current = place
    src = coder.write_program(place, _elements(place), {}, check)
    req = extract_request(be.calls[1][1].text)
    assert [c["id"] for c in req["constraints"]] == ["rests"]  # the tower's check is not asked again
    assert len(req["elements"]) == 3  # the whole legend still
    assert coder.checks_reused == 1 and coder.usage.calls == 2 and checked[-1] == src
    tower = next(n for n in ast.parse(src).body if isinstance(n, ast.FunctionDef) and n.name == "check_tower")
    assert "E[1], E[2]" in ast.unparse(tower)  # green 2 -> 1, red 3 -> 2
    # the renumbered check reads the same blocks: run it on the place subgoal's elements
    pts = {0: np.array([[0.5, 0.0, 0.10]]), 1: np.array([[0.5, 0.0, 0.06]]), 2: np.array([[0.51, 0.0, 0.02]])}
    with Sandbox(deadline_s=1.0) as sb:
        sb.load(src, place.constraints)
        tower_verdict = sb.evaluate(pts, None, None, 0.0)[1]
    assert tower_verdict.ok and tower_verdict.reason == "on 0.010" and tower_verdict.margin == pytest.approx(0.015)


def test_every_constraint_kept_means_no_call_and_any_difference_means_a_call():
    be = Scripted(HELD + "\n" + TOWER_AT.format(g=2, r=3), RESTS, RESTS + "\n" + TOWER_AT.format(g=1, r=2))
    coder = MonitorCoder(be)
    ids = ["held", "tower"]
    coder.write_program(_pick_blue(), _elements(_pick_blue()), {}, basic_check(ids))
    again = Subgoal("pick up the blue block again", _pick_blue().constraints, Action("pick", {"obj": "blue_block"}))
    src = coder.write_program(again, _elements(again), {}, basic_check(ids))
    assert coder.usage.calls == 1 and coder.checks_reused == 2 and src.startswith(REUSED_HEADER)
    # another threshold is another check: asked for
    coder.write_program(_place_blue(_tower(0.03)), _elements(_place_blue()), {}, basic_check(["rests", "tower"]))
    req = extract_request(be.calls[1][1].text)
    assert [c["id"] for c in req["constraints"]] == ["rests", "tower"]


def test_a_combined_program_that_is_rejected_falls_back_to_the_whole_request():
    be = Scripted(HELD + "\n" + TOWER_AT.format(g=2, r=3), RESTS, RESTS + "\n" + TOWER_AT.format(g=1, r=2))
    coder = MonitorCoder(be)
    coder.write_program(_pick_blue(), _elements(_pick_blue()), {}, basic_check(["held", "tower"]))

    def reject_reused(source: str) -> None:
        basic_check(["rests", "tower"])(source)
        if REUSED_HEADER in source:
            raise ProgramError("check_tower: branch never reached")

    src = coder.write_program(_place_blue(), _elements(_place_blue()), {}, reject_reused, max_retries=0)
    assert REUSED_HEADER not in src and coder.checks_reused == 0
    assert [c["id"] for c in extract_request(be.calls[2][1].text)["constraints"]] == ["rests", "tower"]


def test_no_kept_checks_without_reuse_or_after_feedback():
    be = Scripted(HELD + "\n" + TOWER_AT.format(g=2, r=3), RESTS + "\n" + TOWER_AT.format(g=1, r=2),
                  RESTS + "\n" + TOWER_AT.format(g=1, r=2))
    coder = MonitorCoder(be, reuse=False)
    coder.write_program(_pick_blue(), _elements(_pick_blue()), {}, basic_check(["held", "tower"]))
    coder.write_program(_place_blue(), _elements(_place_blue()), {}, basic_check(["rests", "tower"]))
    assert coder.checks_reused == 0 and len(extract_request(be.calls[1][1].text)["constraints"]) == 2
    coder = MonitorCoder(Scripted(HELD + "\n" + TOWER_AT.format(g=2, r=3), RESTS + "\n" + TOWER_AT.format(g=1, r=2)))
    coder.write_program(_pick_blue(), _elements(_pick_blue()), {}, basic_check(["held", "tower"]))
    coder.write_program(_place_blue(), _elements(_place_blue()), {}, basic_check(["rests", "tower"]),
                        feedback="check_tower: branch never reached")
    assert coder.checks_reused == 0
