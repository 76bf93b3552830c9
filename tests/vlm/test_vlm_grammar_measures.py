"""Measures the instruction grammar reads: lengths (metres) and angles (degrees), with their words and bounds."""

from __future__ import annotations

import pytest

from code_as_monitor.vlm.grammar import parse


@pytest.mark.parametrize(("text", "value", "kind", "words"), [
    ("open the drawer 10 cm", 0.10, "length", "10 cm"),
    ("open the drawer by 4 inches", 0.1016, "length", "4 inches"),
    ("turn the left tap 45 degrees", 45.0, "angle", "45 degrees"),
    ("turn the left tap by 60 deg", 60.0, "angle", "60 deg"),
    ("turn the left tap 45\u00b0", 45.0, "angle", "45 degrees"),
    ("turn the left tap a quarter turn", 90.0, "angle", "a quarter turn"),
    ("turn the left tap a quarter-turn", 90.0, "angle", "a quarter turn"),
    ("turn the left tap half a turn", 180.0, "angle", "half a turn"),
    ("turn the left tap a third of a turn", 120.0, "angle", "a third of a turn"),
    ("turn the left tap one quarter of a turn", 90.0, "angle", "one quarter of a turn"),
    ("rotate the left tap a quarter", 90.0, "angle", "a quarter turn"),  # before: refused, a quantity on the tap
    ("twist the right faucet a third", 120.0, "angle", "a third turn"),
    ("rotate the left tap three quarters", 270.0, "angle", "three quarters turn"),
])
def test_a_measure_is_read_with_its_kind_and_words(text: str, value: float, kind: str, words: str) -> None:
    (m,) = parse(text).measures
    assert m.value == pytest.approx(value) and m.kind == kind and m.text == words
    if kind == "length":
        assert m.metres == pytest.approx(value)
    else:
        with pytest.raises(ValueError, match="angle"):
            _ = m.metres


@pytest.mark.parametrize("text", ["turn the left tap", "turn the tap, then turn it back",
                                  "sweep a third of the blocks into the zone", "turn half of the taps",
                                  "sweep the blocks into the zone half"])
def test_turn_as_a_verb_and_fractions_of_things_are_not_angles(text: str) -> None:
    ins = parse(text)
    assert not ins.measures and ins.verbs[0] in ("turn", "sweep")


@pytest.mark.parametrize(("text", "want"), [
    ("put the block in the drawer after opening it", "open it then put the block in the drawer"),
    ("after opening the drawer, put the block in it", "open the drawer then put the block in it"),
    ("open the drawer before putting the block in", "open the drawer then put the block in"),
    ("before putting the block in, open the drawer", "open the drawer then put the block in"),
    ("put the block in the drawer after you open it.", "open it then put the block in the drawer"),
    ("stack green on red after that put blue on green", None),  # "after that" is a separator
    ("put the pen in the holder before the book", None),  # no gerund: not a clause
    ("after opening the drawer put the block in it", None),  # no comma: where the clause ends is not known
])
def test_clauses_are_put_in_the_order_they_happen(text: str, want: str | None) -> None:
    from code_as_monitor.vlm.grammar.tokens import normalise, order_in_time

    words = normalise(text)
    assert " ".join(order_in_time(words)) == (" ".join(words) if want is None else want)


@pytest.mark.parametrize(("text", "want"), [
    ("put blue on the green block, which sits on the red block",
     "put blue on the green block and the green block on the red block"),
    ("stack blue on green, which is on top of red", "stack blue on green and green on top of red"),
    ("put the green block on the red block, which stands on the table",
     "put the green block on the red block and the red block on the table"),
    ("put the blue block on the green block, which is red", None),  # not a place: left to the reader
    ("stack blue on the block that is on red", None),  # restrictive (no comma): it says which block
])
def test_a_clause_placing_what_it_follows_reads_as_another_placement(text: str, want: str | None) -> None:
    from code_as_monitor.vlm.grammar.tokens import normalise, relative_places

    words = normalise(text)
    assert " ".join(relative_places(words)) == (" ".join(words) if want is None else want)
