"""From instruction text to categorised tokens (see :mod:`.lexicon` for the categories).

Steps: lower-case, expand contractions ("don't" -> "do not"), split punctuation, numbers from units ("10cm"),
hyphens ("bottom-up", "twenty-five"); a comma clause placing what it follows as another placement (",
which sits on the red block", :func:`relative_places`); clauses in the order they happen ("X after doing Y" ->
"do Y then X", :func:`order_in_time`); then, left to right, the longest multi-word entry of the lexicon wins
(positions, directions, prepositions, comparisons, quantifiers, nouns, modifiers, separators, fillers),
else a single word by its lemma ("stacking" -> stack, "blocks" -> block). Words that are both a verb and a
noun ("stack", "block", "slot") are verbs at the start of a clause and nouns after a determiner, colour,
number or preposition.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from code_as_monitor.vlm.grammar import lexicon as lx


@dataclass(frozen=True)
class Token:
    """One unit of the instruction. ``kind``: a lexicon category or ``word`` (unknown); ``value``: canonical
    value (str, or float for num/frac/unit); ``text``: the words it covers; ``plural`` for nouns."""

    kind: str
    value: object
    text: str
    plural: bool = False


_CONTRACTIONS = (("n't", " not"), ("'s", " is"), ("'re", " are"), ("'ll", " will"), ("'d", " would"))


def normalise(text: str) -> list[str]:
    """Lower-cased words and punctuation marks."""
    s = text.lower().replace("\u2019", "'").replace("\u2018", "'")
    s = s.replace("can't", "can not").replace("won't", "will not").replace("let's", "let us")
    for a, b in _CONTRACTIONS:
        s = s.replace(a, b)
    s = re.sub(r"(\d)\s*-\s*(\d)", r"\1 to \2", s)  # "6-10 blocks"
    s = re.sub(r"(^|[^\w])-\s*(?=\d)", r"\1 minus ", s)  # "-10 cm": a word the lexicon does not know
    s = s.replace("-", " ")
    s = re.sub(r"(\d+(?:\.\d+)?)\s*(%|cm|mm|m)\b", r"\1 \2", s)
    s = re.sub(r"(\d+(?:\.\d+)?)\s*\u00b0", r"\1 degrees ", s)  # "45\u00b0"
    s = re.sub(r"([,;:.!?()%\"])", r" \1 ", s)
    s = re.sub(r"(?<=\d) \. (?=\d)", ".", s)  # keep decimals
    return [w for w in s.split() if w not in ("?", "(", ")", "\"")]


def lemmas(word: str) -> list[str]:
    """Candidate base forms of ``word``, most likely first."""
    out = [word]
    if word in lx.IRREGULAR:
        out.append(lx.IRREGULAR[word])
    for suffix, repl in (("ies", "y"), ("es", ""), ("s", ""), ("ing", ""), ("ing", "e"), ("ed", ""), ("ed", "e"),
                         ("d", "")):
        if word.endswith(suffix) and len(word) - len(suffix) >= 2:
            stem = word[: len(word) - len(suffix)] + repl
            out.append(stem)
            if suffix in ("ing", "ed") and len(stem) > 2 and stem[-1] == stem[-2]:
                out.append(stem[:-1])  # dropping -> drop, stacked -> stack
    return out


def _number(words: list[str], i: int) -> tuple[float, int] | None:
    """A number starting at ``words[i]`` and the count of words it covers."""
    w = words[i]
    if re.fullmatch(r"\d+(\.\d+)?", w):
        return float(w), 1
    if w in lx.TENS and i + 1 < len(words) and words[i + 1] in lx.NUMBERS and lx.NUMBERS[words[i + 1]] < 10:
        return float(lx.NUMBERS[w] + lx.NUMBERS[words[i + 1]]), 2
    if w == "a" and i + 1 < len(words) and words[i + 1] in ("dozen", "hundred", "pair", "couple"):
        if words[i + 1] == "couple" and i + 2 < len(words) and words[i + 2] == "of":
            return None
        return float(lx.NUMBERS[words[i + 1]]), 2
    if w in lx.NUMBERS and w not in ("couple", "pair"):
        return float(lx.NUMBERS[w]), 1
    return None


_MULTI_TABLES = (
    ("dir", lx.DIRECTIONS), ("mod", {k: v for k, v in lx.MODIFIERS.items() if len(k) > 1}),
    ("prep", lx.MULTI_PREPS), ("pos", {k: v for k, v in lx.POSITIONS.items() if len(k) > 1}),
    ("cmp", {k: v for k, v in lx.COMPARATORS.items() if len(k) > 1}),
    ("quant", {k: v for k, v in lx.QUANTIFIERS.items() if len(k) > 1}), ("noun", lx.MULTI_NOUNS),
    ("sep", {k: v for k, v in lx.SEPARATORS.items() if len(k) > 1}),
    ("filler", {k: "" for k in lx.FILLERS if len(k) > 1}),
)
_LONGEST = max(len(k) for _, table in _MULTI_TABLES for k in table)
_NOUNISH_BEFORE = {"det", "colour", "num", "quant", "prep", "pos", "ord", "cmp", "frac"}


def _multi(words: list[str], i: int) -> tuple[Token, int] | None:
    for n in range(min(_LONGEST, len(words) - i), 1, -1):
        key = tuple(words[i: i + n])
        for kind, table in _MULTI_TABLES:
            if key in table:
                return Token(kind, table[key], " ".join(key), plural=kind == "noun" and key[-1].endswith("s")), n
    return None


def _fraction(words: list[str], i: int, prev: Token | None) -> tuple[Token, int] | None:
    """"half", "a third", "two thirds", "25 %"."""
    w = words[i]
    if w in lx.FRACTIONS and not (w in lx.ORDINALS and prev is not None and prev.kind == "det"
                                  and prev.text not in ("a", "an")):
        return Token("frac", lx.FRACTIONS[w], w), 1
    return None


def _single(word: str, prev: Token | None, nxt: str | None) -> Token:
    """The token of one word given its neighbours."""
    if word in lx.ORDINALS and prev is not None and prev.kind in ("det", "colour"):
        return Token("ord", lx.ORDINALS[word], word)
    if word in lx.SIDES and ((prev is not None and prev.kind in ("det", "colour", "quant"))
                             or (nxt is not None and any(w in lx.NOUNS for w in lemmas(nxt)))):
        return Token("pos", word, word)  # "the left tap", "turn left tap 45 degrees" (not the verb "leave")
    if word == "first" and prev is not None and prev.kind == "det":
        return Token("ord", 1, word)
    if (word,) in lx.SEPARATORS:
        return Token("sep", lx.SEPARATORS[(word,)], word)
    if word in lx.COLOURS:
        return Token("colour", "gray" if word == "grey" else word, word)
    if word in lx.DETERMINERS:
        return Token("det", word, word)
    if word in lx.PRONOUNS:
        return Token("pron", lx.PRONOUNS[word], word)
    if word in lx.NEGATIONS:
        return Token("neg", word, word)
    if word in lx.UNITS and prev is not None and prev.kind == "num":
        return Token("unit", lx.UNITS[word], word)
    if word in lx.ANGLES and prev is not None and prev.kind == "num":
        return Token("angle", lx.ANGLES[word], word)
    if word in lx.PERCENT and prev is not None and prev.kind == "num":
        return Token("unit", "percent", word)
    if (word,) in lx.QUANTIFIERS:
        return Token("quant", lx.QUANTIFIERS[(word,)], word)
    number_follows = nxt is not None and (re.fullmatch(r"\d+(\.\d+)?", nxt) is not None or nxt in lx.NUMBERS)
    if (word,) in lx.COMPARATORS and (number_follows or (word not in lx.PREPS
                                                         and word not in lx.COMPARING_BEFORE_A_NUMBER_ONLY)):
        return Token("cmp", lx.COMPARATORS[(word,)], word)
    if word == "last":
        return Token("ord", -1, word)
    nounish = prev is not None and prev.kind in _NOUNISH_BEFORE and not (
        prev.text == "to" and nxt is not None and nxt in lx.DETERMINERS)  # "to block the opening": a verb
    for lemma in lemmas(word):
        if lemma in lx.VERBS and not (nounish and lemma in lx.NOUNS):
            return Token("verb", lx.VERBS[lemma], word)
        if lemma in lx.NOUNS or word in lx.PLURAL_ONLY:
            concept = lx.PLURAL_ONLY.get(word) or lx.NOUNS[lemma]
            return Token("noun", concept, word, plural=word != lemma or word in lx.PLURAL_ONLY)
    if (word,) in lx.POSITIONS:
        return Token("pos", lx.POSITIONS[(word,)], word)
    if (word,) in lx.MODIFIERS and word not in lx.PREPS:
        return Token("mod", lx.MODIFIERS[(word,)], word)
    if word in lx.PREPS:
        return Token("prep", lx.PREPS[word], word)
    if (word,) in lx.FILLERS:
        return Token("filler", "", word)
    return Token("word", word, word)


_TEMPORAL = ("after", "before")
_TEMPORAL_SKIP = ("having", "you", "we")


def _verb_base(word: str) -> str | None:
    """The verb a gerund or participle stands for ("opening" -> "open", "putting" -> "put"), else None."""
    if not word.endswith(("ing", "ed")):
        return None
    return next((lemma for lemma in lemmas(word)[1:] if lemma in lx.VERBS), None)


def order_in_time(words: list[str]) -> list[str]:
    """Clauses put in the order they happen: "X after doing Y" and "after doing Y, X" read as "do Y then X";
    "X before doing Y" and "before doing Y, X" as "X then do Y". Only when a gerund or participle follows the word
    ("after that" is a separator; "the drawer before the lamp" is left alone)."""
    for i, w in enumerate(words):
        if w not in _TEMPORAL:
            continue
        j = i + 1
        while j < len(words) and words[j] in _TEMPORAL_SKIP:
            j += 1
        if j >= len(words):
            continue
        base = _verb_base(words[j]) or (words[j] if j > i + 1 and words[j] in lx.VERBS else None)  # "after you open"
        if base is None:
            continue
        if i == 0:
            c = next((k for k in range(j, len(words)) if words[k] in (",", ";")), None)
            if c is None:
                continue
            event, main = [base, *words[j + 1:c]], words[c + 1:]  # "after opening the drawer, put ..."
        else:
            main, event = words[:i], [base, *words[j + 1:]]
            while main and main[-1] in (",", ";"):
                main = main[:-1]
        first, second = (event, main) if w == "after" else (main, event)
        while first and first[-1] in (".", "!"):
            first = first[:-1]
        return order_in_time([*first, "then", *second])
    return words


_RESTS = ("is", "sits", "rests", "stands", "lies", "sit", "rest", "stand", "lie")


def relative_places(words: list[str]) -> list[str]:
    """A non-restrictive clause that places what it follows, read as another placement: "put blue on the green block,
    which sits on the red block" -> "put blue on the green block and the green block on the red block". Only after a
    comma, with "which" or "that", a verb of resting and a preposition (what it follows is named again: its words
    back to the preposition, verb or separator before them)."""
    for c in range(1, len(words) - 3):
        if words[c] != "," or words[c + 1] not in ("which", "that") or words[c + 2] not in _RESTS:
            continue
        if words[c + 3] not in lx.PREPS and tuple(words[c + 3:c + 6]) not in lx.MULTI_PREPS \
                and tuple(words[c + 3:c + 5]) not in lx.MULTI_PREPS:
            continue
        j = c
        while j > 0 and words[j - 1] not in lx.PREPS and (words[j - 1],) not in lx.SEPARATORS \
                and not any(lemma in lx.VERBS and lemma not in lx.NOUNS for lemma in lemmas(words[j - 1])):
            j -= 1  # a word both verb and noun ("block") is the noun here
        if j == c:
            continue
        return relative_places([*words[:c], "and", *words[j:c], *words[c + 3:]])
    return words


def tokenize(text: str) -> list[Token]:
    """The instruction as tokens (see the module docstring)."""
    words = order_in_time(relative_places(normalise(text)))
    out: list[Token] = []
    i = 0
    while i < len(words):
        prev = out[-1] if out else None
        multi = _multi(words, i)
        if multi is not None:
            out.append(multi[0])
            i += multi[1]
            continue
        num = _number(words, i)
        if num is not None and not (words[i] == "one" and prev is not None and prev.kind in ("colour", "det")
                                    and not (i + 1 < len(words) and words[i + 1] in lx.FRACTIONS)):
            out.append(Token("num", num[0], " ".join(words[i: i + num[1]])))
            i += num[1]
            continue
        if words[i] in ("a", "an", "one") and i + 1 < len(words) and words[i + 1] in lx.FRACTIONS:
            out.append(Token("frac", lx.FRACTIONS[words[i + 1]], " ".join(words[i: i + 2])))
            i += 2
            continue
        frac = _fraction(words, i, prev)
        if frac is not None:
            out.append(frac[0])
            i += frac[1]
            continue
        out.append(_single(words[i], prev, words[i + 1] if i + 1 < len(words) else None))
        i += 1
    if _bare_turn_fraction(out):
        out.append(Token("noun", "turn", "turn"))  # "rotate the left tap a quarter": a quarter (of a) turn
    return _fix_numbers(out)


def _bare_turn_fraction(out: list[Token]) -> bool:
    """Whether the instruction turns something by a bare fraction at its end ("rotate the left tap a quarter",
    "turn the right tap half"): a verb of turning, then the thing turned, then a fraction and nothing after. A
    fraction of something ("turn half of the taps") or after another verb ("open the drawer half") is not one."""
    k = len(out) - 2  # the thing turned, before the fraction ("a quarter") or its count ("three quarters")
    if k >= 0 and out[k].kind == "num" and out[-1].kind == "frac" and out[-1].text.endswith("s"):
        k -= 1
    return (k >= 1 and out[-1].kind == "frac" and out[k].kind == "noun"
            and any(t.kind == "verb" and t.value == "turn" for t in out[:k]))


def _fix_numbers(tokens: list[Token]) -> list[Token]:
    """Join "two thirds" (num frac) into one fraction, "25 %" (num percent) into a fraction, "2 dozen" into
    one number, and a fraction of a turn ("a quarter turn", "half a turn", "a third of a turn") into an angle
    (the fraction as a number, "turn" as a unit of 360 degrees)."""
    out: list[Token] = []
    for t in tokens:
        if t.text in ("turn", "turns") and _turn_fraction(out):
            words = []
            while out[-1].kind != "frac":
                words.insert(0, out.pop().text)  # "of a", "a" between the fraction and "turn"
            f = out.pop()
            if out and out[-1].kind == "num" and not f.text.endswith("s"):  # "one quarter of a turn"
                n = out.pop()
                f = Token("frac", float(n.value) * float(f.value), f"{n.text} {f.text}")  # type: ignore[arg-type]
            out.append(Token("num", float(f.value), f.text))  # type: ignore[arg-type]
            out.append(Token("angle", 360.0, " ".join([*words, t.text])))
        elif out and out[-1].kind == "num" and t.kind == "num" and t.text in ("dozen", "hundred"):
            n = out.pop()  # "2 dozen", "two hundred"
            out.append(Token("num", float(n.value) * float(t.value), f"{n.text} {t.text}"))  # type: ignore[arg-type]
        elif out and out[-1].kind == "num" and t.kind == "frac" and t.text.endswith("s"):
            n = out.pop()
            out.append(Token("frac", float(n.value) * float(t.value), f"{n.text} {t.text}"))  # type: ignore[arg-type]
        elif out and out[-1].kind == "num" and t.kind == "unit" and t.value == "percent":
            n = out.pop()
            out.append(Token("frac", float(n.value) / 100.0, f"{n.text} {t.text}"))  # type: ignore[arg-type]
        else:
            out.append(t)
    return out


def _turn_fraction(out: list[Token]) -> bool:
    """Whether ``out`` ends with a fraction, then optionally "of", then optionally "a" (before the word "turn")."""
    k = len(out) - 1
    if k >= 0 and out[k].kind == "det" and out[k].text == "a":
        k -= 1
    if k >= 0 and out[k].kind == "prep" and out[k].text == "of":
        k -= 1
    return k >= 0 and out[k].kind == "frac"
