"""The kb is never silently wrong: the instruction table, and instructions generated from the grammar's parts.

The table (``instruction_table.py``) holds instructions across the seven task families with their expected plan
or ``REFUSE``. The generated cases combine phrasings with every tower order and many counts, so they test the
grammar rather than a list of examples. Zero wrong plans is asserted; refusals of plannable instructions are
allowed and printed (run with ``-s`` to see the counts; ``benchmarks/kb_instructions.py`` prints them too).
"""

from __future__ import annotations

import itertools
import math
import random

import pytest
from instruction_table import FIXED, REFUSE, SCENES, TABLE, counts, drawer, judge, rope, sweep, tower

COLOURS = ("red", "green", "blue")

STACK3 = (
    "stack the blocks: {0} at the bottom, then {1}, then {2}",
    "stack {2} on top of {1} on top of {0}",
    "put the {1} block on the {0} block, then the {2} block on the {1} block",
    "build a tower with {0} at the bottom, {1} in the middle and {2} on top",
    "stack the {2}, {1} and {0} blocks from top to bottom",
    "stack the {0}, {1} and {2} blocks from bottom to top",
    "place {0} on the table, {1} on {0} and {2} on {1}",
    "stack the blocks with {2} at the top, {0} at the bottom and {1} in between",
    "put the {0} block under the {1} block and the {2} block on the {1} block",
    "first put {1} on {0}, then put {2} on {1}",
    "stack the {1} cube onto the {0} cube and then the {2} cube onto the {1} cube",
    "I want a tower of three blocks: {0} at the base, {1} second from the bottom, {2} on top",
    "stack {0}, then {1}, then {2}",
    "stack {2} above {1} and {1} above {0}",
    "stack the blocks from top to bottom: {2}, {1}, {0}",
    "Could you stack the {1} one on the {0} one and then put the {2} one on top?",
    "pick up the {1} block, place it on the {0} block, then pick up the {2} block and put it on the {1} block",
    "the {2} block should end up on the {1} block, and the {1} block on the {0} block",
    "stack all three blocks so that {1} is in the middle, {2} is at the top and {0} is at the bottom",
    "make a stack: {0} first, then {1}, finally {2}",
    "stack {0} {1} {2}",
)
STACK2 = (
    "put the {1} block on the {0} block",
    "stack {1} on {0}",
    "place the {1} cube on top of the {0} one",
    "put the {0} block under the {1} block",
    "move the {1} block onto the {0} block",
)
STACK_BAD = (
    "stack the {0} block on the {0} block",
    "stack {0} on {1} and {1} on {0}",
    "put the {0} block on the {1} block and the {2} block on the {1} block",
    "stack the blocks with {0} in the middle",
    "stack the yellow block on the {0} block",
    "put the {0} block beside the {1} block",
    "stack the {0} block on the {1} block without the {2} block",
    "stack {0} at the bottom and {1} at the bottom",
)


def _stack_cases() -> list[tuple[str, str, object]]:
    out = []
    for order in itertools.permutations(COLOURS):
        out += [("stack", t.format(*order), tower(*order)) for t in STACK3]
        out += [("stack", t.format(*order), REFUSE) for t in STACK_BAD]
    for a, b in itertools.permutations(COLOURS, 2):
        out += [("stack", t.format(a, b), tower(a, b)) for t in STACK2]
    return out


NUMBER_WORDS = {1: "one", 2: "two", 3: "three", 5: "five", 7: "seven", 10: "ten", 12: "twelve", 15: "fifteen",
                20: "twenty", 25: "twenty-five", 30: "thirty", 33: "thirty three", 40: "forty"}


def _band(centre: float, n: int = 40, count: bool = False) -> tuple[int, int, int]:
    """The sweep band's rule, restated: +-10 % of all blocks (of the count itself for a plain count), clipped to
    1..n, halting below the centre unless the band reaches every block."""
    tol = 0.1 * (centre if count else n)
    lo, hi = max(1, math.ceil(centre - tol - 1e-9)), min(n, math.floor(centre + tol + 1e-9))
    target = round(centre) if hi >= n else max(lo, round(centre - 0.5 * tol))
    return lo, hi, min(hi, target)


def _sweep_cases(seed: int = 7) -> list[tuple[str, str, object]]:
    rng = random.Random(seed)
    out: list[tuple[str, str, object]] = []
    verbs = ("push", "sweep", "Please push", "slide")
    places = ("into the zone", "into the target area", "into the marked region", "inside the zone", "onto the zone")
    for k in sorted(set(rng.sample(range(1, 41), 14)) | {1, 10, 20, 40}):
        word = NUMBER_WORDS.get(k, str(k))
        v, p = rng.choice(verbs), rng.choice(places)
        out.append(("sweep", f"{v} {k} blocks {p}", sweep(*_band(k, count=True))))
        out.append(("sweep", f"{v} {word} of the blocks {p}", sweep(*_band(k, count=True))))
        out.append(("sweep", f"{v} about {word} blocks {p}", sweep(*_band(k))))
        out.append(("sweep", f"{v} exactly {k} blocks {p}", sweep(k, k, k)))
        out.append(("sweep", f"{v} at least {k} blocks {p}", sweep(k, 40, k)))
    for words, frac in (("half of the", 0.5), ("a third of the", 1 / 3), ("a quarter of the", 0.25),
                        ("two thirds of the", 2 / 3), ("three quarters of the", 0.75), ("10% of the", 0.1),
                        ("half the", 0.5), ("all the", 1.0), ("every one of the", 1.0)):
        v, p = rng.choice(verbs), rng.choice(places)
        out.append(("sweep", f"{v} {words} blocks {p}", sweep(*_band(40 * frac))))
    for bad in ("push 41 blocks into the zone", "push zero blocks into the zone", "push fewer than 5 blocks into "
                "the zone", "push a few blocks into the zone", "push 120% of the blocks into the zone",
                "sweep half of the blocks away from the zone", "push half of the 20 blocks into the zone",
                "push 10 blocks into the red zone", "push 10 blocks", "push the green blocks into the zone"):
        out.append(("sweep", bad, REFUSE))
    return out


LENGTHS = (("5 cm", 0.05), ("6cm", 0.06), ("8 centimetres", 0.08), ("ten centimeters", 0.10), ("0.12 m", 0.12),
           ("120 mm", 0.12), ("3 inches", 0.0762), ("15 cm", 0.15), ("12.5 cm", 0.125))
DRAWER = (
    "open the drawer {0}", "pull the drawer out {0}", "open the drawer by {0}", "pull the drawer open by {0}",
    "grasp the handle and pull the drawer out {0}", "slide the drawer out {0} by its handle",
    "open the drawer at least {0}", "please open the cabinet drawer about {0}", "pull out the drawer {0}",
)
DRAWER_BAD = ("open the drawer up to {0}", "open the drawer exactly {0}", "open the drawer no more than {0}",
              "open the drawer less than {0}", "close the drawer {0}", "open the drawer {0} and then {0}",
              "push the drawer in {0}")


def _drawer_cases() -> list[tuple[str, str, object]]:
    out: list[tuple[str, str, object]] = []
    for words, metres in LENGTHS:
        out += [("drawer", t.format(words), drawer(metres)) for t in DRAWER]
        out += [("drawer", t.format(words), REFUSE) for t in DRAWER_BAD]
    for words in ("4 cm", "16 cm", "20 cm", "1 m", "0 cm", "10 inches", "-10 cm"):
        out += [("drawer", t.format(words), REFUSE) for t in DRAWER[:4]]
    for t in ("open the drawer halfway", "pull the drawer halfway out", "slide the drawer open halfway"):
        out.append(("drawer", t, drawer(0.125)))
    for t in ("open the drawer fully", "pull the drawer all the way out", "open the drawer completely",
              "open the drawer wide"):
        out.append(("drawer", t, REFUSE))
    return out


FRACTIONS = (("half of", 0.5), ("half", 0.5), ("a third of", 1 / 3), ("two thirds of", 2 / 3),
             ("three quarters of", 0.75), ("80% of", 0.8), ("at least 90 percent of", 0.9), ("100% of", 1.0),
             ("about 60 % of", 0.6), ("more than half of", 0.5))
ROPE = ("close {0} the opening with the rope", "use the rope to close {0} the opening of the square",
        "seal {0} the gap in the square using the cord", "cover {0} the open side of the square with the string")


def _rope_cases() -> list[tuple[str, str, object]]:
    out: list[tuple[str, str, object]] = []
    for words, frac in FRACTIONS:
        out += [("rope", t.format(words), rope(round(frac, 4))) for t in ROPE]
    for words in ("10% of", "a fifth of", "at most half of", "exactly half of", "less than half of",
                  "120% of", "no more than 80% of"):
        out += [("rope", t.format(words), REFUSE) for t in ROPE]
    for t in ("put the rope into the square", "put the rope on the square", "drag the rope across the square",
              "stack the rope on the square", "close the opening with two ropes", "put the rope next to the opening"):
        out.append(("rope", t, REFUSE))
    return out


GENERATED = _stack_cases() + _sweep_cases() + _drawer_cases() + _rope_cases()


def test_the_table_covers_every_family_with_enough_rows():
    assert len(TABLE) >= 60
    assert {scene for scene, _, _ in TABLE} == set(SCENES)
    assert sum(expected == REFUSE for _, _, expected in TABLE) >= 15


def test_instruction_table_has_no_wrong_plan():
    total, misses = counts(TABLE)
    print(f"\ninstruction table ({len(TABLE)} rows, kb stand-in): right {total['right']}, refused "
          f"{total['refused']}, wrong {total['wrong']}")
    for verdict, instruction, detail in misses:
        print(f"  {verdict}: {instruction!r}: {detail[:160]}")
    assert total["wrong"] == 0, [m for m in misses if m[0] == "wrong"]


def test_generated_instructions_have_no_wrong_plan():
    total, misses = counts(GENERATED)
    print(f"\ngenerated instructions ({len(GENERATED)}, kb stand-in): right {total['right']}, refused "
          f"{total['refused']}, wrong {total['wrong']}")
    assert total["wrong"] == 0, [m for m in misses if m[0] == "wrong"][:5]
    # the grammar reads the generated phrasings: refusals of plannable ones stay rare
    plannable = sum(expected != REFUSE for _, _, expected in GENERATED)
    assert total["refused"] <= 0.1 * plannable, [m for m in misses if m[0] == "refused"][:5]


@pytest.mark.parametrize("instruction", ["stack the yellow block on the red block", "push 50 blocks into the zone",
                                         "close the drawer", "put the pencil in the cup"])
def test_a_refusal_names_what_it_did_not_understand_in_one_line(instruction):
    scene = {"stack": "stack", "push": "sweep", "close": "drawer", "put": "pen"}[instruction.split()[0]]
    verdict, detail = judge(instruction, SCENES[scene], REFUSE)
    assert verdict == "right" and "\n" not in detail
    named = {"stack": "yellow", "push": "40 blocks", "close": "'close'", "put": "pencil"}[instruction.split()[0]]
    assert named in detail


def test_random_word_salad_is_planned_or_refused_never_crashes():
    """Words of the lexicon in random order: the kb either refuses with an InstructionError or gives answers
    that pass the generator's schema; any other exception fails the test."""
    from code_as_monitor.core.errors import InstructionError
    from code_as_monitor.vlm.grammar import lexicon as lx
    from code_as_monitor.vlm.kb.planner import next_subgoal
    from code_as_monitor.vlm.schemas import parse_generator_output

    rng = random.Random(11)
    words = [*lx.NOUNS, *lx.VERBS, *lx.PREPS, *lx.COLOURS, *lx.NUMBERS, *lx.FRACTIONS,
             *(" ".join(k) for k in lx.POSITIONS), *(" ".join(k) for k in lx.MODIFIERS),
             ",", "then", "and", "the", "a", "it", "them", "%", "10", "3.5", "cm", "-", "'s", "of the", ":", "."]
    for _ in range(400):
        text = " ".join(rng.choice(words) for _ in range(rng.randint(1, 12)))
        objects = SCENES[rng.choice(list(SCENES))]
        try:
            answer = next_subgoal({"instruction": text, "objects": objects})
        except InstructionError:
            continue
        parse_generator_output(answer, {"objects": objects})


@pytest.mark.parametrize("instruction", [
    "push half of the blocks in the pile into the zone",
    "sweep half of the pile into the yellow zone",
    "push half the blocks from the pile into the zone",
    "sweep a quarter of the pile into the zone",
])
def test_the_sweep_scenes_pile_is_its_blocks(instruction):
    """The sweep scene's blocks lie in a pile: "the pile" names them (where they lie, or what to push), as "the
    blocks on the table" does; before, each of these was refused for the unknown pile."""
    band = (6, 14, 8) if "quarter" in instruction else (16, 24, 18)
    assert judge(instruction, SCENES["sweep"], sweep(*band)) == ("right", "")


@pytest.mark.parametrize(("scene", "instruction", "want"), [
    ("pen", "put the pen into the holder with the tip down", FIXED["pen"]),  # "with the" before a manner it honours
    ("pen", "insert the pen into the holder with its point first", FIXED["pen"]),
    ("tea", "tilt the teapot to pour the tea into the cup", FIXED["tea"]),  # tilting is how the pot pours
    ("tea", "pour the tea into the cup by tilting the teapot", FIXED["tea"]),
    # before: "1 blocks: the scene has 3" (the count of the tower read as a count of blocks)
    ("stack", "stack all three blocks into a single tower, red at the base and blue at the top",
     tower("red", "green", "blue")),
    ("stack", "build a tower of red, green and blue blocks, bottom to top",  # before: the list began after "of"
     tower("red", "green", "blue")),
    ("stack", "stack red and green, red at the bottom", tower("red", "green")),  # before: "contradictory"
    ("stack", "put the blue block on top of the green block, which sits on the red block",  # before: "which"
     tower("red", "green", "blue")),
    # ways of asking: a wish, a task statement, "let's" (read as "let is" before)
    ("stack", "I'd like the red block on top of the green one", tower("green", "red")),
    ("stack", "I would like the blue block on the red block", tower("red", "blue")),
    ("stack", "let's stack green on red", tower("red", "green")),
    ("stack", "your task is to stack the blue block on the green block", tower("green", "blue")),
    ("drawer", "the goal is to open the drawer", FIXED["drawer"]),
    ("tea", "your job is to pour the tea from the teapot into the teacup", FIXED["tea"]),
    # turning the pen or book upright is the reorientation step of its plan (before: "cannot 'turn' here")
    ("book", "pick up the book, turn it upright and put it in the bookshelf", FIXED["book"]),
    ("pen", "pick up the pen, turn it upright and put it into the holder", FIXED["pen"]),
    ("pen", "rotate the pen upright and insert it into the holder", FIXED["pen"]),
    # the clause after a colon says how the one before it is done, with the same verb (before: "pour twice")
    ("tea", "serve tea: pour from the teapot into the teacup", FIXED["tea"]),
    ("drawer", "open the drawer: open it by pulling its handle", FIXED["drawer"]),
    # a pronoun opening its own clause after "so (that)" stands for the thing before it (before: "no use for 'it'")
    ("rope", "arrange the rope so that it closes the square", rope(0.9)),
    ("rope", "arrange the rope so it closes the square", rope(0.9)),
    # "stand ... up" is the pen's reorientation too, as the book's (before: "cannot honour 'up'")
    ("pen", "stand the pen up in its holder", FIXED["pen"]),
    # a little: the least the kb opens the drawer, 5 cm (before: "did not understand 'little'")
    ("drawer", "pull out the drawer a little", drawer(0.05)),
    ("drawer", "open the drawer slightly", drawer(0.05)),
    ("drawer", "open the drawer a bit", drawer(0.05)),
    ("drawer", "could you open the drawer just a little bit?", drawer(0.05)),  # "just" before no number: a filler
    ("drawer", "open the drawer a tiny bit", drawer(0.05)),
    ("stack", "just put the red block on the green block", tower("green", "red")),
])
def test_these_phrasings_plan_the_task_not_a_refusal(scene: str, instruction: str, want: list) -> None:
    verdict, detail = judge(instruction, SCENES[scene], want)
    assert verdict == "right", detail


def test_just_before_a_number_still_asks_for_exactly_that():
    """"just 10 cm" is exactly 10 cm, which the kb cannot promise (it checks the opening from below only)."""
    verdict, detail = judge("open the drawer just 10 cm", SCENES["drawer"], REFUSE)
    assert verdict == "right" and "just 10 cm" in detail
