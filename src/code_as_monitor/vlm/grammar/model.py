"""What the grammar reads from an instruction: phrases, the relations between them, listings, verbs and the rest.

Indices refer to :attr:`Instruction.phrases`. Nothing here knows a task: the kb's task families read these
structures and decide what they mean for their task (and refuse what they cannot honour).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from code_as_monitor.vlm.grammar.tokens import Token


@dataclass(frozen=True)
class Quantity:
    """How many of something.

    Attributes:
        kind: ``number`` ("10 blocks"), ``fraction`` ("half of the blocks", "25 %"), ``all`` ("all", "every",
            "both": ``of_total`` 2), ``some`` ("some", "a few") or ``none`` ("no", "none").
        value: the count, or the fraction in [0, 1]; 1.0 for ``all``.
        bound: ``plain``, ``about``, ``exact``, ``at_least``, ``at_most``, ``more``, ``fewer`` or ``between``.
        high: the upper value of a ``between`` range ("between 6 and 10").
        of_total: the total a count is taken of ("10 of the 40 blocks" -> 40).
        text: the words.
    """

    kind: str
    value: float
    bound: str = "plain"
    high: float | None = None
    of_total: float | None = None
    text: str = ""


@dataclass
class Phrase:
    """A noun phrase ("the red block", "half of the blocks", "it", "green").

    Attributes:
        index: position in :attr:`Instruction.phrases`.
        head: the noun's concept (:data:`~code_as_monitor.vlm.grammar.lexicon.NOUNS`), ``""`` for a bare colour
            or quantity ("red", "half"), inherited across a coordination ("the red, green and blue blocks").
        colour: its colour adjective, ``""`` if none.
        quantity: its quantity, or None.
        plural, definite: "blocks"; "the ...".
        position: ``bottom``, ``middle``, ``top`` or ``table`` ("red at the bottom", "the top block"), or a side
            ``left``/``right`` ("the left tap").
        ordinal: 1, 2, ... or -1 (last) with ``ordinal_from`` ``bottom`` or ``top`` ("the second from the top").
        pronoun: ``it`` or ``them`` for a pronoun; ``ref`` is then the index of the phrase it stands for.
        verb: the canonical verb of its clause (``""`` if none).
        role: ``object`` (no preposition before it) or ``complement`` (after a preposition).
        segment: which part of the instruction (parts are split at separators: then , ; and : .).
        start, end: token span.
        text: the words.
    """

    index: int
    head: str = ""
    colour: str = ""
    quantity: Quantity | None = None
    plural: bool = False
    definite: bool = False
    position: str = ""
    ordinal: int = 0
    ordinal_from: str = ""
    pronoun: str = ""
    ref: int | None = None
    verb: str = ""
    role: str = "object"
    segment: int = 0
    start: int = 0
    end: int = 0
    text: str = ""


@dataclass(frozen=True)
class Link:
    """A preposition between two phrases: ``a`` (the phrase before it in the same part, or None) ``kind`` ``b``;
    ``words`` the preposition as written.

    ``kind`` is canonical (:data:`~code_as_monitor.vlm.grammar.lexicon.PREPS`): "red on top of green" ->
    ``on(red, green)``; "the pen into the holder" -> ``into(pen, holder)``; "the opening of the square" ->
    ``of(opening, square)``.
    """

    kind: str
    a: int | None
    b: int
    words: str = ""


@dataclass(frozen=True)
class Listing:
    """Phrases named one after another with only separators between them ("red, green and blue", "red at the
    bottom, then green, then blue"); none of them takes part in a :class:`Link`. ``connectors[i]`` joins
    ``items[i]`` and ``items[i + 1]`` (``then`` wins over ``and`` and ``,``)."""

    items: tuple[int, ...]
    connectors: tuple[str, ...]


@dataclass(frozen=True)
class Measure:
    """A length ("10 cm": ``value`` in metres) or an angle ("45 degrees": ``value`` in degrees, ``kind``
    ``angle``); ``text`` the words; ``bound`` as in :class:`Quantity` (``plain``, ``about``, ``exact``,
    ``at_least``, ``at_most``, ``more``, ``fewer``): "at least 10 cm", "up to 10 cm"."""

    value: float
    text: str
    bound: str = "plain"
    kind: str = "length"

    @property
    def metres(self) -> float:
        """The length in metres (a ValueError for an angle: a reader asks ``kind`` first)."""
        if self.kind != "length":
            raise ValueError(f"{self.text!r} is an angle, not a length")
        return self.value


@dataclass(frozen=True)
class Instruction:
    """A parsed instruction.

    Attributes:
        text: as given.
        tokens: the categorised tokens.
        phrases, links, listings: see the classes above.
        verbs: canonical verbs in order ("stack", "put", "pour", ...).
        modifiers: canonical manner / end-state words in order ("upright", "out", "tip_down", ...).
        directions: ``up`` / ``down`` for a listing read bottom-to-top or top-to-bottom.
        measures: lengths and angles.
        negations: negation words ("not", "without", ...).
        unknown: words outside the lexicon, in order.
        stray: known words the parser could attach to nothing (a dangling number, a lone "the").
    """

    text: str
    tokens: tuple[Token, ...] = ()
    phrases: tuple[Phrase, ...] = ()
    links: tuple[Link, ...] = ()
    listings: tuple[Listing, ...] = ()
    verbs: tuple[str, ...] = ()
    modifiers: tuple[str, ...] = ()
    directions: tuple[str, ...] = ()
    measures: tuple[Measure, ...] = ()
    negations: tuple[str, ...] = ()
    unknown: tuple[str, ...] = ()
    stray: tuple[str, ...] = ()
    heads: frozenset[str] = field(default_factory=frozenset)

    @property
    def lower(self) -> str:
        return self.text.lower()

    def resolve(self, i: int) -> Phrase:
        """Phrase ``i``, or the phrase a pronoun stands for."""
        p = self.phrases[i]
        while p.pronoun and p.ref is not None and p.ref != p.index:
            p = self.phrases[p.ref]
        return p

    def links_of(self, kind: str) -> list[Link]:
        """The links of one kind, in order."""
        return [k for k in self.links if k.kind == kind]

    def linked(self) -> set[int]:
        """Indices of phrases that take part in a link."""
        return {k.b for k in self.links} | {k.a for k in self.links if k.a is not None}

    def with_head(self, *heads: str) -> list[Phrase]:
        """The phrases (pronouns resolved) whose head is one of ``heads``."""
        return [p for p in self.phrases if self.resolve(p.index).head in heads]

    def show(self, i: int) -> str:
        """Phrase ``i`` quoted, for messages."""
        return repr(self.phrases[i].text)
