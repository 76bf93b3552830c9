"""A family's reading of a parsed instruction: what it used, so that nothing is silently ignored.

Every family's ``understand`` follows the same steps: decide whether the instruction is about it (else None),
then read it with a :class:`Reading`: check the verbs and modifiers it can honour, mark each phrase and link it
gives a role, and :meth:`Reading.finish` raises :class:`~code_as_monitor.core.errors.InstructionError` naming
anything left over. A goal is returned only for a complete reading.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import NoReturn

from code_as_monitor.core.errors import InstructionError
from code_as_monitor.vlm.grammar import Instruction, Link, Phrase

_PREP_WORDS = {"on": "on", "under": "under", "above": "above", "below": "below", "into": "into", "from": "from",
               "with": "with", "out_of": "out of", "to": "to", "of": "of", "by": "by", "at": "at", "off": "off",
               "next_to": "next to", "in_front_of": "in front of", "away_from": "away from", "up_to": "up to"}


def check_generic(ins: Instruction, families: str) -> None:
    """Refuse what no family reads: unknown words, negations, an empty instruction. ``families`` lists them."""
    if not ins.text.strip():
        raise InstructionError(f"kb: the instruction is empty; the kb knows these task families: {families}")
    if ins.unknown:
        words = ", ".join(repr(w) for w in dict.fromkeys(ins.unknown))
        raise InstructionError(f"kb: did not understand {words} in {ins.text!r}; the kb (a rule-based stand-in for a "
                               f"VLM) knows these task families: {families}")
    if ins.negations:
        words = ", ".join(repr(w) for w in dict.fromkeys(ins.negations))
        raise InstructionError(f"kb: cannot plan a negated request ({words} in {ins.text!r}); say what to do, not "
                               f"what not to do")


def scene_names(objects: Iterable[str]) -> list[str]:
    """Object names without the ``"obj/part"`` entries."""
    return [o for o in objects if "/" not in o]


def link_text(ins: Instruction, k: Link) -> str:
    """"the red block on the green block" for a link, for messages."""
    a = ins.phrases[k.a].text + " " if k.a is not None else ""
    return f"{a}{k.words or _PREP_WORDS.get(k.kind, k.kind)} {ins.phrases[k.b].text}"


class Reading:
    """One family's reading of ``ins``; ``task`` names the family's task in messages.

    ``heads`` and ``verbs`` are the family's own nouns and verbs: how many of the instruction's phrases and
    verbs use them is the reading's relevance, which ranks the refusals of several families (the kb reports
    those of the families that recognised most of the instruction)."""

    def __init__(self, ins: Instruction, task: str, heads: Iterable[str] = (), verbs: Iterable[str] = ()) -> None:
        self.ins = ins
        self.task = task
        hs, vs = set(heads), set(verbs)
        self.relevance = sum(ins.resolve(p.index).head in hs for p in ins.phrases) + sum(v in vs for v in ins.verbs)
        self.used: set[int] = set()
        self.used_links: set[int] = set()
        self.used_mods: set[int] = set()
        self.used_measures: set[int] = set()
        self.used_directions = False

    def refuse(self, why: str) -> NoReturn:
        exc = InstructionError(f"kb ({self.task}): {why} in {self.ins.text!r}")
        exc.relevance = self.relevance  # type: ignore[attr-defined]
        raise exc

    # --- vocabulary ----------------------------------------------------------------------------------------
    def verbs(self, allowed: Iterable[str], doing: str, once: bool = False) -> None:
        """Every verb is one of ``allowed``; ``doing`` says what the family does (for the message). ``once``: the
        family does one thing, so a verb said twice ("pour ... and then pour it back") is a second action."""
        bad = [v for v in self.ins.verbs if v not in set(allowed)]
        if bad:
            self.refuse(f"cannot {bad[0]!r} here; this task family {doing}")
        again = [v for i, v in enumerate(self.ins.verbs) if v in self.ins.verbs[:i]]
        if once and again:
            self.refuse(f"cannot {again[0]!r} twice; this task family {doing}, once")

    def modifiers(self, allowed: Iterable[str], doing: str) -> None:
        """Every modifier is one of ``allowed`` (they are marked used)."""
        ok = set(allowed)
        for i, m in enumerate(self.ins.modifiers):
            if m not in ok:
                self.refuse(f"cannot honour {m.replace('_', ' ')!r}; this task family {doing}")
            self.used_mods.add(i)

    # --- marking -------------------------------------------------------------------------------------------
    def use(self, *indices: int | None) -> None:
        self.used.update(i for i in indices if i is not None)

    def use_link(self, k: Link) -> None:
        self.used_links.add(self.ins.links.index(k))

    def phrases(self, where: Callable[[Phrase], bool]) -> list[Phrase]:
        """The phrases (pronouns resolved) for which ``where`` holds."""
        return [p for p in self.ins.phrases if where(self.ins.resolve(p.index))]

    def links(self, kinds: Iterable[str], target: Callable[[Phrase], bool]) -> list[Link]:
        """Links of one of ``kinds`` whose second phrase (resolved) satisfies ``target``."""
        ks = set(kinds)
        return [k for k in self.ins.links if k.kind in ks and target(self.ins.resolve(k.b))]

    # --- the end -------------------------------------------------------------------------------------------
    def finish(self) -> None:
        """Refuse anything this reading gave no role (phrases, links, measures, directions, strays)."""
        ins = self.ins
        for i, k in enumerate(ins.links):
            if i not in self.used_links:
                self.refuse(f"does not understand {link_text(ins, k)!r}")
        for p in ins.phrases:
            if p.index not in self.used and not (p.pronoun and p.ref in self.used):
                self.refuse(f"has no use for {p.text!r}")
        for i, m in enumerate(ins.measures):
            if i not in self.used_measures:
                self.refuse(f"cannot honour the length {m.text!r}")
        if ins.directions and not self.used_directions:
            self.refuse("has no listing to read " + ("bottom to top" if ins.directions[0] == "up" else "top to bottom"))
        for i, m in enumerate(ins.modifiers):
            if i not in self.used_mods:
                self.refuse(f"cannot honour {m.replace('_', ' ')!r}")
        if ins.stray:
            self.refuse(f"cannot place {' '.join(ins.stray)!r}")


def read_placement(r: Reading, objects: list[str], *, item: tuple[str, ...], item_obj: Callable[[str], bool],
                   place: tuple[str, ...], place_obj: Callable[[str], bool], preps: tuple[str, ...],
                   what: str, where: str, place_optional: bool = False) -> tuple[str, str]:
    """The common reading of "<verb> the <item> <prep> the <place>" (a pen into its holder, a book into the
    shelf): one phrase whose head is in ``item`` and at most one (resolved) whose head is in ``place``, joined
    by a link of ``preps``; "from the table" is allowed. Grounded on ``objects`` with the predicates; returns
    ``(item object, place object)``. ``what``/``where`` name them in messages."""
    ins = r.ins
    names = scene_names(objects)
    items = r.phrases(lambda p: p.head in item)
    places = r.phrases(lambda p: p.head in place)
    if not items:
        r.refuse(f"say what to move: the {what}")
    if not places and not place_optional:
        r.refuse(f"say where the {what} goes: into the {where}")
    for p in items + places:
        q = ins.resolve(p.index)
        if q.colour or (q.quantity is not None and (q.quantity.value != 1 or q.quantity.of_total not in (None, 1))) \
                or q.position or q.ordinal:
            r.refuse(f"{p.text!r}: the scene has one {what} and one {where}")
        r.use(p.index)
    for k in ins.links:
        b = ins.resolve(k.b).head
        if (k.kind in preps and b in place) or (k.kind == "from" and b == "table"):
            r.use_link(k)
            r.use(k.b)
    if places and not any(k.kind in preps and ins.resolve(k.b).head in place for k in ins.links):
        r.refuse(f"say where the {what} goes: into the {where}")
    if sum(k.kind in preps and ins.resolve(k.b).head in place for k in ins.links) > 1:
        r.refuse(f"say one place for the {what}: the scene has one {where}")
    obj = next((o for o in names if item_obj(o)), "")
    dest = next((o for o in names if place_obj(o)), "")
    if not obj:
        r.refuse(f"the scene has no {what}")
    if not dest:
        r.refuse(f"the scene has no {where}")
    return obj, dest
