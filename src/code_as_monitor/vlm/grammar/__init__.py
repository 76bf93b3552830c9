"""The shared grammar of instructions: the parse every kb task family grounds on the scene."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Instruction:
    """A parsed instruction. ``text``: as given; ``lower``: lower-cased."""

    text: str

    @property
    def lower(self) -> str:
        return self.text.lower()


def parse(text: str) -> Instruction:
    """Parse ``text``."""
    return Instruction(str(text))


__all__ = ["Instruction", "parse"]
