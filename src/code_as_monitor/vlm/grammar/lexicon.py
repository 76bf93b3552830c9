"""The words the instruction grammar knows, each with its category and canonical value.

Categories (``Token.kind``):

========= ======================================================================================
verb      an action, by lemma ("stacking" -> ``stack``; "pick up" -> ``pick``)
noun      an object concept ("pencil cup" -> ``holder``, "bookcase" -> ``shelf``, "cup" -> ``cup``)
colour    a colour adjective
num       a number ("ten", "10", "twenty-five", "a dozen")
frac      a fraction of a whole ("half", "a third", "two thirds", "25 %")
quant     a quantifier: ``all`` (all, every, each, both, whole), ``some``, ``none`` (no, none)
cmp       a comparison on a count: ``about``, ``exact``, ``at_least``, ``at_most``, ``more``, ``fewer``,
          ``between``
det       a determiner ("the", "a", "its", ...)
prep      a spatial relation, canonical: ``on`` (on, onto, on top of, atop), ``under`` (under, beneath,
          underneath), ``above``, ``below``, ``into`` (into, in, inside), ``from``, ``with`` (with,
          using), ``out_of``, ``to``, ``of``, ``by``, ``at``, ``off``, ``next_to``, ``between``, ...
pos       a place in a stack: ``bottom``, ``middle``, ``top`` ("at the bottom", "as the base", "on top"), or a
          side: ``left``, ``right`` ("the left tap", "the tap on the right")
ord       an ordinal: ``1`` (first), ``2`` (second), ... ; ``-1`` (last)
dir       the direction of a listing: ``up`` ("from bottom to top") or ``down`` ("from top to bottom")
sep       a separator between parts: ``then`` (then, after that, next, finally), ``and``, ``,``, ``;``,
          ``:``, ``.``
neg       a negation: not, never, without, except, but
mod       a manner or end state: ``upright``, ``flat``, ``out``, ``in``, ``open``, ``closed``,
          ``halfway``, ``slightly``, ``fully``, ``tip_down``, ``level``, ``up``, ``down``
unit      a length unit, value in metres per unit
angle     an angle unit after a number (degree, degrees, deg), value in degrees per unit
pron      a pronoun: ``it`` (it, this, that), ``them`` (them, they, these, those)
filler    a word that changes nothing (please, carefully, so that, is, ...)
========= ======================================================================================

Words not listed here are unknown: the kb refuses an instruction with an unknown word, naming it.
"""

from __future__ import annotations

COLOURS = ("red", "green", "blue", "yellow", "orange", "purple", "pink", "white", "black", "brown", "gray", "grey",
           "cyan", "magenta", "violet")

NOUNS: dict[str, str] = {
    # stacking and sweeping
    "block": "block", "cube": "block", "brick": "block", "one": "one",
    "tower": "tower", "pile": "tower", "stack": "tower",
    "zone": "zone", "region": "zone", "area": "zone", "target": "zone", "goal": "zone", "patch": "zone",
    # rope
    "rope": "rope", "cord": "rope", "string": "rope", "cable": "rope",
    "opening": "opening", "gap": "opening", "hole": "opening", "entrance": "opening", "side": "side",
    "square": "square", "outline": "square", "frame": "square", "shape": "square", "enclosure": "square",
    # pen
    "pen": "pen", "ballpoint": "pen", "biro": "pen", "holder": "holder", "pencil": "pencil", "marker": "marker",
    # book
    "book": "book", "shelf": "shelf", "bookshelf": "shelf", "bookcase": "shelf", "slot": "slot",
    # drawer
    "drawer": "drawer", "handle": "handle", "knob": "handle", "cabinet": "cabinet", "cupboard": "cabinet",
    "dresser": "cabinet",
    # tea
    "tea": "tea", "teapot": "teapot", "kettle": "teapot", "pot": "pot", "teacup": "teacup", "mug": "teacup",
    "cup": "cup",
    # RLBench-style tasks
    "item": "item", "object": "item", "thing": "item",
    "bulb": "bulb", "lightbulb": "bulb", "lamp": "lamp", "socket": "socket", "fitting": "socket",
    "tap": "tap", "faucet": "tap", "lever": "handle",
    "stick": "stick", "rod": "stick", "pole": "stick",
    "dirt": "dirt", "dust": "dirt", "debris": "dirt", "crumb": "dirt", "particle": "dirt",
    "dustpan": "dustpan", "pan": "dustpan", "broom": "broom", "brush": "broom",
    # the scene
    "table": "table", "tabletop": "table", "desk": "table",
}
"""Noun (singular) -> concept. ``cup`` and ``pot`` stay ambiguous (a teacup or a pencil cup; a teapot or a pen
pot): the family that reads them decides, with the scene. ``one`` stands for the noun of its neighbours."""

PLURAL_ONLY = {"shelves": "shelf", "bookshelves": "shelf", "bookcases": "shelf"}

MULTI_NOUNS: dict[tuple[str, ...], str] = {
    ("pen", "holder"): "holder", ("pencil", "holder"): "holder", ("pencil", "cup"): "holder",
    ("pen", "cup"): "holder", ("pen", "pot"): "holder", ("pencil", "pot"): "holder", ("pen", "jar"): "holder",
    ("pencil", "jar"): "holder", ("ballpoint", "pen"): "pen",
    ("book", "shelf"): "shelf", ("book", "case"): "shelf", ("shelf", "slot"): "slot",
    ("tea", "pot"): "teapot", ("tea", "cup"): "teacup", ("tea", "mug"): "teacup",
    ("chest", "of", "drawers"): "cabinet", ("drawer", "handle"): "handle", ("drawer", "cabinet"): "cabinet",
    ("table", "top"): "table",
    ("light", "bulb"): "bulb", ("bulb", "socket"): "socket", ("lamp", "socket"): "socket",
    ("dust", "pan"): "dustpan", ("water", "tap"): "tap",
    ("target", "zone"): "zone", ("target", "area"): "zone", ("target", "region"): "zone",
    ("goal", "zone"): "zone", ("goal", "area"): "zone", ("goal", "region"): "zone", ("marked", "zone"): "zone",
    ("marked", "area"): "zone", ("marked", "region"): "zone", ("marked", "square"): "zone",
    ("open", "side"): "opening", ("missing", "side"): "opening", ("open", "end"): "opening",
}

VERBS: dict[str, str] = {
    "stack": "stack", "pile": "stack", "build": "build", "make": "build", "form": "build", "create": "build",
    "assemble": "build",
    "put": "put", "place": "put", "set": "put", "lay": "put", "move": "put", "position": "put", "bring": "put",
    "get": "put", "carry": "put", "transfer": "put", "leave": "put",
    "pick": "pick", "lift": "pick", "grasp": "grasp", "grab": "grasp", "grip": "grasp", "take": "pick",
    "hold": "hold",
    "drop": "drop", "insert": "insert", "slot": "insert", "stick": "insert", "slide": "slide", "stand": "stand",
    "push": "push", "sweep": "sweep", "brush": "sweep", "shove": "push", "nudge": "push", "herd": "push",
    "close": "close", "enclose": "close", "seal": "close", "shut": "close", "cover": "close", "block": "close",
    "bridge": "close", "span": "close", "complete": "close", "fill": "fill",
    "use": "use", "drag": "drag", "arrange": "arrange", "lay out": "arrange",
    "open": "open", "pull": "pull", "draw": "pull", "yank": "pull",
    "pour": "pour", "serve": "pour", "tip": "pour", "decant": "pour", "empty": "pour",
    "tilt": "tilt", "incline": "tilt",
    "screw": "screw", "install": "screw", "turn": "turn", "rotate": "turn", "twist": "turn",
    "shelve": "shelve", "stow": "stow", "store": "stow", "return": "stow", "file": "stow", "tidy": "stow",
}
"""Verb lemma -> canonical action."""

PREPS: dict[str, str] = {
    "on": "on", "onto": "on", "atop": "on", "upon": "on", "under": "under", "beneath": "under",
    "underneath": "under", "above": "above", "over": "above", "below": "below", "into": "into", "in": "into",
    "inside": "into", "within": "into", "from": "from", "with": "with", "using": "with", "to": "to",
    "towards": "to", "toward": "to", "of": "of", "by": "by", "at": "at", "off": "off", "beside": "next_to",
    "between": "between", "behind": "behind", "across": "across", "along": "along", "through": "through",
    "around": "around", "against": "against", "near": "next_to",
}

MULTI_PREPS: dict[tuple[str, ...], str] = {
    ("on", "top", "of"): "on", ("on", "to"): "on", ("in", "to"): "into", ("out", "of"): "out_of",
    ("next", "to"): "next_to", ("in", "front", "of"): "in_front_of", ("on", "the", "top", "of"): "on",
    ("right", "on", "top", "of"): "on", ("directly", "on"): "on", ("directly", "on", "top", "of"): "on",
    ("down", "into"): "into", ("away", "from"): "away_from", ("up", "to"): "up_to",
}

POSITIONS: dict[tuple[str, ...], str] = {
    ("at", "the", "bottom"): "bottom", ("on", "the", "bottom"): "bottom", ("at", "the", "base"): "bottom",
    ("as", "the", "base"): "bottom", ("on", "the", "table"): "table", ("bottom",): "bottom", ("base",): "bottom",
    ("lowest",): "bottom", ("at", "the", "top"): "top", ("on", "top"): "top", ("on", "the", "top"): "top",
    ("top",): "top", ("topmost",): "top", ("uppermost",): "top", ("highest",): "top",
    ("at", "the", "very", "top"): "top",
    ("on", "the", "very", "top"): "top", ("in", "the", "middle"): "middle", ("in", "the", "center"): "middle",
    ("in", "the", "centre"): "middle", ("middle",): "middle", ("in", "between"): "middle",
    ("at", "bottom"): "bottom", ("on", "bottom"): "bottom", ("at", "top"): "top", ("in", "middle"): "middle",
    ("on", "the", "left"): "left", ("on", "the", "right"): "right", ("left", "hand"): "left",
    ("right", "hand"): "right",
    ("at", "the", "bottom", "of", "the", "tower"): "bottom", ("at", "the", "top", "of", "the", "tower"): "top",
    ("in", "the", "middle", "of", "the", "tower"): "middle", ("on", "top", "of", "the", "tower"): "top",
}
"""Places in a stack. ``("on", "the", "table")`` is a position too (at the bottom, resting on the table).
``left``/``right`` name one of a pair side by side ("the left tap", "the tap on the right"); the single words
"left" and "right" are positions only after a determiner or a colour (else "left" is the verb "leave")."""

SIDES = ("left", "right")

DIRECTIONS: dict[tuple[str, ...], str] = {
    ("from", "bottom", "to", "top"): "up", ("from", "the", "bottom", "to", "the", "top"): "up",
    ("bottom", "to", "top"): "up", ("from", "the", "bottom", "up"): "up", ("bottom", "up"): "up",
    ("from", "the", "bottom"): "up", ("starting", "from", "the", "bottom"): "up",
    ("starting", "at", "the", "bottom"): "up", ("from", "top", "to", "bottom"): "down",
    ("from", "the", "top", "to", "the", "bottom"): "down", ("top", "to", "bottom"): "down",
    ("from", "the", "top", "down"): "down", ("top", "down"): "down", ("from", "the", "top"): "down",
    ("starting", "from", "the", "top"): "down", ("starting", "at", "the", "top"): "down",
}

SEPARATORS: dict[tuple[str, ...], str] = {
    ("then",): "then", ("and", "then"): "then", ("after", "that"): "then", ("afterwards",): "then",
    ("next",): "then", ("finally",): "then", ("lastly",): "then", ("followed", "by"): "then",
    ("and", "finally"): "then", ("first",): "first", ("firstly",): "first", ("first", "of", "all"): "first",
    ("and",): "and", (",",): ",", (";",): ";", (":",): ":", (".",): ".", ("!",): ".",
}

COMPARATORS: dict[tuple[str, ...], str] = {
    ("about",): "about", ("around",): "about", ("roughly",): "about", ("approximately",): "about",
    ("approx",): "about", ("some",): "about", ("nearly",): "about", ("almost",): "about",
    ("exactly",): "exact", ("precisely",): "exact", ("just",): "exact",
    ("at", "least"): "at_least", ("no", "fewer", "than"): "at_least", ("no", "less", "than"): "at_least",
    ("a", "minimum", "of"): "at_least", ("at", "most"): "at_most", ("no", "more", "than"): "at_most",
    ("up", "to"): "at_most", ("a", "maximum", "of"): "at_most", ("not", "more", "than"): "at_most",
    ("more", "than"): "more", ("over",): "more", ("fewer", "than"): "fewer", ("less", "than"): "fewer",
    ("under",): "fewer", ("between",): "between",
}
"""Words before a number. ``over``, ``under`` and ``between`` are comparisons only when a number follows."""

QUANTIFIERS: dict[tuple[str, ...], str] = {
    ("all",): "all", ("all", "of"): "all", ("every",): "all", ("each",): "all", ("each", "of"): "all",
    ("both",): "both", ("whole",): "all", ("entire",): "all", ("all", "the"): "all", ("none",): "none",
    ("no",): "none", ("several",): "some", ("some",): "some", ("a", "few"): "some", ("a", "couple", "of"): "some",
    ("many",): "some", ("most",): "some", ("any",): "some",
}

DETERMINERS = {"the", "a", "an", "this", "that", "these", "those", "its", "their", "my", "your", "our", "his",
               "her"}

NUMBERS: dict[str, int] = {
    "zero": 0, "one": 1, "two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8,
    "nine": 9, "ten": 10, "eleven": 11, "twelve": 12, "thirteen": 13, "fourteen": 14, "fifteen": 15,
    "sixteen": 16, "seventeen": 17, "eighteen": 18, "nineteen": 19, "twenty": 20, "thirty": 30, "forty": 40,
    "fifty": 50, "sixty": 60, "seventy": 70, "eighty": 80, "ninety": 90, "hundred": 100, "dozen": 12,
    "single": 1, "pair": 2, "couple": 2,
}
TENS = {"twenty", "thirty", "forty", "fifty", "sixty", "seventy", "eighty", "ninety"}

FRACTIONS: dict[str, float] = {
    "half": 1 / 2, "halves": 1 / 2, "third": 1 / 3, "thirds": 1 / 3, "quarter": 1 / 4, "quarters": 1 / 4,
    "fourth": 1 / 4, "fourths": 1 / 4, "fifth": 1 / 5, "fifths": 1 / 5, "tenth": 1 / 10, "tenths": 1 / 10,
}
PERCENT = {"%", "percent", "per cent", "pc"}

ORDINALS: dict[str, int] = {"second": 2, "third": 3, "fourth": 4, "fifth": 5, "last": -1}
"""Ordinals of a stack level ("the second block from the bottom"); "first" is a separator ("first ..., then")."""

UNITS: dict[str, float] = {
    "m": 1.0, "metre": 1.0, "meter": 1.0, "metres": 1.0, "meters": 1.0, "cm": 0.01, "centimetre": 0.01,
    "centimeter": 0.01, "centimetres": 0.01, "centimeters": 0.01, "mm": 0.001, "millimetre": 0.001,
    "millimeter": 0.001, "millimetres": 0.001, "millimeters": 0.001, "inch": 0.0254, "inches": 0.0254,
}

ANGLES: dict[str, float] = {"degree": 1.0, "degrees": 1.0, "deg": 1.0, "degs": 1.0}
"""Angle units after a number ("turn the left tap 45 degrees", "45°"), degrees per unit. A fraction of a turn ("a
quarter turn", "half a turn") is an angle too: the tokenizer joins it (360 degrees a turn)."""

MODIFIERS: dict[tuple[str, ...], str] = {
    ("upright",): "upright", ("vertically",): "upright", ("vertical",): "upright", ("standing",): "upright",
    ("standing", "up"): "upright", ("on", "its", "end"): "upright", ("on", "end"): "upright",
    ("straight", "up"): "upright", ("spine", "out"): "upright", ("spine", "first"): "upright",
    ("flat",): "flat", ("lying", "down"): "flat", ("horizontally",): "flat", ("on", "its", "side"): "flat",
    ("lying",): "flat", ("out",): "out", ("outwards",): "out", ("open",): "open", ("opened",): "open",
    ("closed",): "closed", ("shut",): "closed", ("in",): "in", ("halfway",): "halfway",
    ("half", "way"): "halfway", ("slightly",): "slightly", ("a", "little"): "slightly",
    ("a", "little", "bit"): "slightly", ("a", "bit"): "slightly", ("a", "crack"): "slightly",
    ("a", "tiny", "bit"): "slightly", ("a", "little", "way"): "slightly", ("a", "touch"): "slightly",
    ("fully",): "fully",
    ("all", "the", "way"): "fully", ("completely",): "fully",
    ("wide",): "fully", ("tip", "first"): "tip_down", ("tip", "down"): "tip_down", ("point", "first"): "tip_down",
    ("point", "down"): "tip_down", ("nib", "first"): "tip_down", ("nib", "down"): "tip_down",
    ("writing", "end", "down"): "tip_down", ("level",): "level", ("up",): "up", ("down",): "down",
    ("together",): "together", ("neatly",): "neat", ("in", "order"): "in_order", ("in", "this", "order"): "in_order",
    ("in", "that", "order"): "in_order", ("in", "any", "order"): "any_order",
    ("in", "no", "particular", "order"): "any_order", ("in", "whatever", "order"): "any_order",
    ("in", "the", "order"): "in_order", ("in", "sequence"): "in_order",
    ("in", "a", "tower"): "in_tower", ("into", "a", "tower"): "in_tower", ("into", "one", "tower"): "in_tower",
    ("in", "one", "tower"): "in_tower", ("into", "a", "single", "tower"): "in_tower",
    ("in", "a", "single", "tower"): "in_tower", ("into", "a", "stack"): "in_tower",
    ("into", "one", "stack"): "in_tower", ("into", "a", "single", "stack"): "in_tower",
    ("on", "top", "of", "each", "other"): "in_tower", ("on", "top", "of", "one", "another"): "in_tower",
    ("one", "on", "top", "of", "the", "other"): "in_tower", ("by", "its", "handle"): "by_handle",
    ("by", "the", "handle"): "by_handle",
}
MODIFIERS.update({("with", det, *k): v for k, v in list(MODIFIERS.items()) if v == "tip_down"
                  for det in ("the", "its")})  # "with the tip down", "with its point first"
MODIFIERS.update({("with", *k): v for k, v in list(MODIFIERS.items()) if v == "tip_down" and k[0] != "with"})
"""Manner and end states. Each family says which it honours; any other makes it refuse, naming the words."""

NEGATIONS = {"not", "never", "without", "except", "but", "avoid", "avoiding", "instead"}

PRONOUNS: dict[str, str] = {"it": "it", "them": "them", "they": "them"}

OPENABLE = frozenset({"drawer", "cabinet", "tap"})
"""What opens: the things "open" takes, and among those "pull" and "turn" take."""
MOVABLE = frozenset({"block", "pen", "pencil", "marker", "book", "teapot", "teacup", "cup", "pot", "item", "bulb",
                     "stick", "rope", "broom"})
"""What the hand picks up, puts, inserts or drags (not the table, a shelf, a zone, a tower or a cabinet)."""
OBJECT_OF: dict[str, frozenset[str]] = {
    "open": OPENABLE, "pull": OPENABLE | MOVABLE, "turn": OPENABLE | {"bulb"},
    **{v: MOVABLE for v in ("pick", "grasp", "hold", "put", "insert", "drop", "slide", "stand", "drag", "stow",
                            "shelve", "screw", "pour", "tilt")},
}
"""Canonical verb -> the concepts it can take as its object: where a pronoun has nothing before it to stand for,
it stands for the one thing named after it that its verb can take (``parse._Parser.finish``)."""

COMPARING_BEFORE_A_NUMBER_ONLY = {"just"}
"""Comparators that compare only before a number ("just 10 cm": exactly); elsewhere they are fillers ("just open the
drawer")."""

FILLERS: set[tuple[str, ...]] = {
    ("please",), ("kindly",), ("do",), ("just", "do"), ("just",), ("now",), ("carefully",), ("gently",), ("robot",),
    ("go", "ahead", "and"),
    ("can", "you"), ("could", "you"), ("would", "you"), ("will", "you"), ("you",), ("i", "want", "you", "to"),
    ("i", "would", "like", "you", "to"), ("i", "need", "you", "to"), ("i", "want"), ("i", "need"),
    ("i", "would", "like", "to"), ("i", "would", "like"), ("your", "task", "is", "to"), ("the", "goal", "is", "to"),
    ("your", "goal", "is", "to"), ("the", "job", "is", "to"), ("your", "job", "is", "to"),
    ("we", "need"), ("so", "that"), ("such", "that"), ("so",), ("is",), ("are",), ("be",), ("ends", "up"),
    ("end", "up"), ("sits",), ("sit",), ("goes",), ("go",), ("rests",), ("rest",), ("lies",), ("should",),
    ("must",), ("need", "to"), ("needs", "to"), ("try", "to"), ("want",), ("task",), ("your",), ("the", "task",
    "is", "to"), ("then", "you"), ("let", "us"), ("let's",), ("for", "me"), ("as", "follows"), ("order",),
    ("ordered",), ("sorted",), ("one", "by", "one"), ("one", "at", "a", "time"), ("with",), ("there",),
    ("like", "this"), ("to",), ("of",), ("way",), ("all", "together"), ("up", "to", "you"), ("back",), ("away",),
    ("for", "me"), ("for", "us"), ("properly",), ("again",), ("which", "is"), ("which", "are"),
}
"""Phrases that change nothing about the task. ``with``, ``to`` and ``of`` are fillers only where the parser
finds no phrase after them (``with`` before a position, ``to`` before a verb)."""

IRREGULAR: dict[str, str] = {
    "put": "put", "set": "set", "laid": "lay", "took": "take", "brought": "bring", "got": "get", "made": "make",
    "built": "build", "left": "leave", "held": "hold", "drew": "draw", "drawn": "draw", "stood": "stand",
    "shut": "shut", "swept": "sweep", "slid": "slide", "stuck": "stick", "dropped": "drop", "placing": "place",
    "blocks": "block", "boxes": "box", "shelves": "shelf", "halves": "half", "pieces": "piece",
}
