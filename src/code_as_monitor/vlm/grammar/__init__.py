"""The shared grammar of instructions: ``parse(text) -> Instruction``, which every kb task family grounds.

- :mod:`.lexicon`: the words it knows (verbs, object nouns and their synonyms, colours, numbers, fractions,
  prepositions, positions in a stack, directions, comparisons, modifiers, fillers).
- :mod:`.tokens`: text -> categorised tokens (multi-word entries, lemmas, numbers).
- :mod:`.parse`: tokens -> phrases, links between them, listings, verbs, modifiers, measures.
- :mod:`.model`: the data classes.

The grammar knows no task: it reads structure ("X on top of Y", "then", "at the bottom", "half of", "10
blocks"); what that structure means for a task, and whether it can be honoured, is the task family's call.
"""

from code_as_monitor.vlm.grammar.model import Instruction, Link, Listing, Measure, Phrase, Quantity
from code_as_monitor.vlm.grammar.parse import parse

__all__ = ["Instruction", "Link", "Listing", "Measure", "Phrase", "Quantity", "parse"]
