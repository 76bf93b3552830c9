"""The shallow parser: tokens -> :class:`~code_as_monitor.vlm.grammar.model.Instruction`.

One pass, left to right. Separators (then , ; and : .) split the instruction into parts; a verb starts a
clause whose verb carries over to following parts that have none ("stack blue on green, then red on blue").
Noun phrases are built from determiners, quantities, colours, ordinals and a noun ("half of the 40 blocks",
"the second block from the top", "the red one"); a preposition links the phrase before it in the same part
to the phrase after it ("red on top of green on top of blue" -> on(red, green), on(green, blue)); a
preposition with no phrase after it is a particle ("pull the drawer out"). Positions ("at the bottom", "on
top") attach to the phrase before them in the part, else to the next one. Then: pronouns are resolved, a
coordination shares its noun ("the red, green and blue blocks"), "one" takes its neighbours' noun, and
listings are collected.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from code_as_monitor.vlm.grammar import lexicon as lx
from code_as_monitor.vlm.grammar.model import Instruction, Link, Listing, Measure, Phrase, Quantity
from code_as_monitor.vlm.grammar.tokens import Token, tokenize

_OBJECT_PARTICLES = {("pick", "up"), ("put", "down")}
"""A verb's particle that may also follow its object ("pick it up", "set the block down on the red one")."""
_PARTICLE_VERBS = {"pick", "stack", "build", "stand", "put", "open", "pull", "close", "fill", "use", "push", "sweep"}


@dataclass
class _NP:
    """A noun phrase being read."""

    start: int
    det: str = ""
    quant: str = ""
    cmp: str = ""
    nums: list[float] = field(default_factory=list)
    frac: float | None = None
    fracs: int = 0  # fractions read: "half of half of the opening" has two (no one fraction)
    of_seen: bool = False
    nums_before_of: int = 0
    colour: str = ""
    ordinal: int = 0
    position: str = ""
    noun: str = ""
    plural: bool = False
    pronoun: str = ""
    words: list[str] = field(default_factory=list)

    def empty(self) -> bool:
        return not (self.noun or self.colour or self.pronoun or self.nums or self.frac is not None or self.quant)


class _Parser:
    def __init__(self, tokens: list[Token]) -> None:
        self.t = tokens
        self.phrases: list[Phrase] = []
        self.links: list[Link] = []
        self.verbs: list[str] = []
        self.mods: list[str] = []
        self.dirs: list[str] = []
        self.measures: list[Measure] = []
        self.negs: list[str] = []
        self.unknown: list[str] = []
        self.stray: list[str] = []
        self.segment = 0
        self.verb = ""
        self.last: int | None = None  # last phrase of the current part
        self.prep: tuple[str, int | None, str] | None = None  # (kind, anchor, words)
        self.pos = ""  # a position waiting for the next phrase
        self.np: _NP | None = None
        self.seps: dict[int, list[str]] = {}  # separators before the phrase with this index
        self.colon_verb = ""  # the verb before a ":" not yet followed by another verb

    # --- phrases -------------------------------------------------------------------------------------------
    def close(self, end: int) -> None:
        np, self.np = self.np, None
        if np is None:
            return
        if np.empty():
            self.stray.extend(np.words)
            return
        q = self._quantity(np)
        if not (np.noun or np.colour or np.pronoun) and q is not None and self.last is not None \
                and self.phrases[self.last].quantity is None and self.prep is None:
            self.phrases[self.last].quantity = q  # "push them all"
            return
        idx = len(self.phrases)
        p = Phrase(idx, head=np.noun, colour=np.colour, quantity=q, plural=np.plural or bool(q and q.value > 1),
                   definite=np.det in ("the", "this", "that", "these", "those", "its", "their"),
                   position=np.position, ordinal=np.ordinal, pronoun=np.pronoun, verb=self.verb,
                   segment=self.segment, start=np.start, end=end, text=" ".join(np.words))
        if self.pos and not p.position:
            p.position, self.pos = self.pos, ""
        if self.prep is not None:
            kind, anchor, words = self.prep
            self.links.append(Link(kind, anchor, idx, words))
            p.role, self.prep = "complement", None
        self.phrases.append(p)
        self.last = idx

    @staticmethod
    def _quantity(np: _NP) -> Quantity | None:
        words = " ".join(np.words)
        bound = np.cmp or "plain"
        if np.quant == "none":
            return Quantity("none", 0.0, bound, text=words)
        if np.quant == "both":  # all of two: a family with another count refuses it by ``of_total``
            return Quantity("all", 1.0, bound, of_total=2.0, text=words)
        after_of = np.nums[np.nums_before_of:] if np.of_seen else []
        total = after_of[-1] if after_of else None
        if np.fracs > 1:
            return Quantity("some", 0.0, "ambiguous", text=words)  # "half of half of": no one fraction read
        if np.frac is not None:
            return Quantity("fraction", np.frac, bound, of_total=total, text=words)
        if np.quant == "all" and np.nums:  # "all 40 blocks", "all of the 40 blocks", "every one of the blocks"
            return Quantity("all", 1.0, bound, of_total=total if np.of_seen else np.nums[-1], text=words)
        before = np.nums[: np.nums_before_of] if np.of_seen else np.nums
        if len(before) > 1 and bound != "between":
            return Quantity("some", 0.0, "ambiguous", text=words)  # "10 12 blocks": no one count
        if before and (np.noun or np.colour or np.of_seen or np.det == "" or np.quant):
            high = before[1] if bound == "between" and len(before) > 1 else None
            return Quantity("number", before[0], bound, high=high, of_total=total, text=words)
        if np.nums and not before:
            return Quantity("all", 1.0, bound, of_total=np.nums[-1], text=words)  # "the 40 blocks"
        if np.quant == "all":
            return Quantity("all", 1.0, bound, text=words)
        if np.quant == "some":
            return Quantity("some", 0.0, bound, text=words)
        return None

    def np_token(self, i: int, tok: Token) -> None:
        np = self.np
        if np is not None and (np.noun or np.pronoun) and tok.kind in ("det", "quant", "num", "colour", "pron",
                                                                        "noun", "cmp", "frac"):
            self.close(i)
            np = None
        if np is not None and np.colour and tok.kind in ("colour", "det", "quant", "pron", "cmp"):
            self.close(i)
            np = None
        if np is None:
            np = self.np = _NP(start=i)
        np.words.append(tok.text)
        if tok.kind == "det":
            np.det = np.det or str(tok.value)
        elif tok.kind == "quant":
            np.quant = str(tok.value)
        elif tok.kind == "cmp":
            np.cmp = str(tok.value)
        elif tok.kind == "num":
            np.nums.append(float(tok.value))  # type: ignore[arg-type]
        elif tok.kind == "frac":
            np.fracs += 1
            np.frac = float(tok.value)  # type: ignore[arg-type]
        elif tok.kind == "colour":
            np.colour = str(tok.value)
        elif tok.kind == "ord":
            np.ordinal = int(tok.value)  # type: ignore[arg-type]
        elif tok.kind == "noun":
            np.noun, np.plural = str(tok.value), tok.plural
        elif tok.kind == "pron":
            np.pronoun = str(tok.value)
            np.plural = tok.value == "them"

    # --- the pass ------------------------------------------------------------------------------------------
    def run(self) -> None:
        t = self.t
        i = 0
        while i < len(t):
            tok = t[i]
            nxt = t[i + 1] if i + 1 < len(t) else None
            k = tok.kind
            if k in ("det", "quant", "num", "frac", "colour", "ord", "noun", "pron", "cmp"):
                self.np_token(i, tok)
            elif k == "prep" and tok.value == "of" and self.np is not None and not self.np.noun \
                    and (self.np.nums or self.np.frac is not None or self.np.quant):
                self.np.of_seen = True  # "half of the blocks", "10 of the 40 blocks"
                self.np.nums_before_of = len(self.np.nums)
                self.np.words.append(tok.text)
            elif k in ("sep", "prep") and tok.text in ("and", "to") and self.np is not None and self.np.nums \
                    and not self.np.noun and nxt is not None and nxt.kind == "num":
                self.np.cmp = "between"  # "between 6 and 10", "6 to 10"
                self.np.words.append(tok.text)
            elif k == "pos" and self.np is not None and not self.np.noun and nxt is not None \
                    and nxt.kind in ("noun", "colour"):
                self.np.position = str(tok.value)  # "the top block"
                self.np.words.append(tok.text)
            elif k in ("unit", "angle"):
                self.unit(i, tok)
            else:
                if k == "pos" and self.np is not None and self.np.det and self.np.empty():
                    self.np = None  # "the base", "the top" are places, not phrases
                self.close(i)
                self.other(i, tok, nxt)
            i += 1
        self.close(len(t))
        self.dangle()
        if self.pos:
            self.stray.append(self.pos)  # a place with no phrase after it

    def unit(self, i: int, tok: Token) -> None:
        np = self.np
        if np is not None and len(np.nums) == 1 and not (np.noun or np.colour or np.frac is not None):
            self.np = None
            bound, words = np.cmp or "plain", [*np.words, tok.text]
            if self.prep is not None and self.prep[0] == "up_to":
                bound, words = "at_most", [self.prep[2], *words]  # "up to 10 cm"
            kind = "angle" if tok.kind == "angle" else "length"
            self.measures.append(Measure(np.nums[0] * float(tok.value), " ".join(words), bound, kind))
            if self.prep is not None and self.prep[0] in ("by", "to", "up_to"):
                self.prep = None  # "by 10 cm"
            return
        self.close(i)
        self.stray.append(tok.text)

    def dangle(self) -> None:
        """A preposition with no phrase after it is a particle ("pull it out", "push the drawer in")."""
        if self.prep is not None:
            kind, _, words = self.prep
            self.mods.append({"into": "in"}.get(kind, kind if kind in ("out", "off", "up", "down") else words))
            self.prep = None

    def other(self, i: int, tok: Token, nxt: Token | None) -> None:
        k, v = tok.kind, tok.value
        if k == "sep":
            self.dangle()
            self.segment += 1
            self.last = None
            self.seps.setdefault(len(self.phrases), []).append(str(v))
            if str(v) == ":":
                self.colon_verb = self.verb
        elif k == "verb":
            if self.prep is not None and self.prep[0] in ("by", "to", "with"):
                self.prep = None  # "by pulling", "to close", "with ... to"
            self.dangle()
            again = str(v) == self.colon_verb  # "serve tea: pour it from the pot into the cup" says how, once
            self.verb, self.colon_verb = str(v), ""
            if not again:
                self.verbs.append(self.verb)
        elif k == "prep":
            self.dangle()
            if nxt is not None and nxt.kind == "verb" and v in ("by", "to", "with"):
                return  # "by pulling its handle", "to close the opening"
            if nxt is None or nxt.kind in ("sep", "verb", "mod", "dir"):
                self.mods.append({"into": "in"}.get(str(v), str(v)))
                return
            self.prep = (str(v), self.last, tok.text)
        elif k == "pos":
            self.dangle()
            if self.last is not None and not self.phrases[self.last].position:
                self.phrases[self.last].position = str(v)
            elif self.last is None and not self.pos:
                self.pos = str(v)  # "on top: blue", "at the bottom, red"
            else:
                self.stray.append(tok.text)  # a second place for one phrase: nothing to attach it to
        elif k == "dir":
            last = self.phrases[self.last] if self.last is not None else None
            if last is not None and last.ordinal and not last.ordinal_from:
                last.ordinal_from = "bottom" if v == "up" else "top"
            else:
                self.dirs.append(str(v))
        elif k == "mod":
            prev = self.t[i - 1] if i else None
            if prev is not None and prev.kind == "verb" and (
                    (v == "up" and prev.value in _PARTICLE_VERBS) or (prev.value, v) in _OBJECT_PARTICLES):
                return  # "pick up", "stack up", "set down"
            if (self.verb, v) in _OBJECT_PARTICLES and self.np is None and self.prep is None and self.last is not None \
                    and self.phrases[self.last].verb == self.verb and self.phrases[self.last].role == "object" \
                    and self.phrases[self.last].end == i:
                return  # "pick the pen up", "set it down on ...": the particle after the object
            self.dangle()
            self.mods.append(str(v))
        elif k == "neg":
            self.negs.append(tok.text)
        elif k == "word":
            self.unknown.append(tok.text)
        elif k == "filler":
            if tok.text == "with" and self.prep is None and nxt is not None:
                self.prep = ("with", self.last, "with")
        else:
            self.stray.append(tok.text)

    # --- after the pass ------------------------------------------------------------------------------------
    def finish(self) -> None:
        ps = self.phrases
        trailing = [w for w in self.seps.get(len(ps), []) if w in ("first", "then")]
        self.stray.extend(trailing)  # "stack the blocks with blue first": an order word with nothing after it
        for p in ps:  # pronouns
            if p.pronoun:
                want_plural = p.pronoun == "them"
                subject = self._clause_subject(p)  # "arrange the rope so that it closes the square": the rope
                cands = [q for q in ps[: p.index] if not q.pronoun and (q.segment != p.segment or subject)
                         and (q.plural == want_plural or not want_plural)]
                objs = [q for q in cands if q.role == "object"]
                pick = (objs or cands)[-1] if (objs or cands) else None
                if pick is None:  # nothing before it ("put the cube in the drawer after opening it", read in the
                    # order things happen: "open it then put the cube in the drawer"): the one thing named after it
                    # in another part that its verb can take, or the one such thing that is a verb's object there;
                    # none or several, and it stays unresolved
                    fit = [q for q in ps[p.index + 1:] if not q.pronoun and q.segment != p.segment
                           and q.plural == want_plural and q.head in lx.OBJECT_OF.get(p.verb, ())]
                    if len({(q.head, q.colour) for q in fit}) > 1:
                        fit = [q for q in fit if q.role == "object"]
                    pick = fit[0] if len({(q.head, q.colour) for q in fit}) == 1 else None
                p.ref = pick.index if pick is not None else None
        for p in reversed(ps):  # "the red, green and blue blocks": the last noun is every colour's
            nxt = ps[p.index + 1] if p.index + 1 < len(ps) else None
            if (p.colour and not p.head and nxt is not None and nxt.colour and nxt.head
                    and p.segment != nxt.segment and set(self.seps.get(nxt.index, [])) <= {",", "and"}
                    and nxt.plural):
                p.head, p.plural = nxt.head, True
        for p in ps:  # "the red one"
            if p.head == "one":
                others = [q.head for q in ps if q.head not in ("", "one")]
                near = sorted(ps, key=lambda q: abs(q.index - p.index))
                p.head = next((q.head for q in near if q.head not in ("", "one")), others[0] if others else "")

    def _clause_subject(self, p: Phrase) -> bool:
        """Whether pronoun phrase ``p`` opens a clause of its own as its subject: right after "so that", "so" or
        "such that", with a verb right after it ("... so that it closes the square"). Such a pronoun may stand for a
        phrase before it in its own part; an object pronoun may not ("put the block on it": not the block)."""
        before = self.t[p.start - 1] if p.start > 0 else None
        after = self.t[p.end] if p.end < len(self.t) else None
        return (before is not None and before.kind == "filler" and before.text in ("so that", "so", "such that")
                and after is not None and after.kind == "verb")

    def listings(self) -> list[Listing]:
        linked = {k.b for k in self.links} | {k.a for k in self.links if k.a is not None}
        # "a tower of red, green and blue": the first member is the complement of "of", the others follow it
        members = {k.b for k in self.links if k.kind == "of" and k.a is not None and self.phrases[k.a].head == "tower"}
        out: list[Listing] = []
        run: list[int] = []
        conns: list[str] = []
        for p in self.phrases:
            seps = self.seps.get(p.index, [])
            prev = self.phrases[run[-1]] if run else None
            adjacent = prev is not None and p.start == prev.end and p.segment == prev.segment  # "red green blue"
            joined = prev is not None and p.index not in linked and (
                (bool(seps) and p.segment > prev.segment) or adjacent)
            if joined:
                run.append(p.index)
                conns.append("then" if "then" in seps else ("and" if "and" in seps else (seps[-1] if seps else "")))
                continue
            if len(run) >= 2:
                out.append(Listing(tuple(run), tuple(conns)))
            run, conns = ([p.index], []) if p.index not in linked or p.index in members else ([], [])
        if len(run) >= 2:
            out.append(Listing(tuple(run), tuple(conns)))
        return out


def parse(text: str) -> Instruction:
    """Parse ``text`` into an :class:`Instruction` (never raises on words it does not know: they are listed
    in ``unknown``)."""
    tokens = tokenize(str(text))
    p = _Parser(tokens)
    p.run()
    p.finish()
    return Instruction(
        text=str(text), tokens=tuple(tokens), phrases=tuple(p.phrases), links=tuple(p.links),
        listings=tuple(p.listings()), verbs=tuple(p.verbs), modifiers=tuple(p.mods), directions=tuple(p.dirs),
        measures=tuple(p.measures), negations=tuple(p.negs), unknown=tuple(p.unknown), stray=tuple(p.stray),
        heads=frozenset(q.head for q in p.phrases if q.head),
    )
