"""Orders of a stack (bottom first) that satisfy what an instruction says about it.

Constraints: ``on`` (x directly on y), ``above`` (x somewhere above y), ``at`` (x at a level: 0 bottom, -1 top,
``"middle"`` the middle of an odd-sized stack, k the k-th from the bottom, -k the k-th from the top) and
``sequences`` (items listed bottom first, consecutive). The stacks are few (a handful of items), so every
permutation is tried: the answer is every order consistent with all constraints, so a caller can tell
"exactly one" from "contradictory" (none) from "under-specified" (several).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise, permutations


@dataclass
class OrderConstraints:
    """What an instruction says about a stack of ``items``."""

    items: list[str]
    on: list[tuple[str, str]] = field(default_factory=list)
    above: list[tuple[str, str]] = field(default_factory=list)
    at: list[tuple[str, int | str]] = field(default_factory=list)
    sequences: list[list[str]] = field(default_factory=list)

    def empty(self) -> bool:
        return not (self.on or self.above or self.at or self.sequences)


def _level(n: int, where: int | str) -> int | None:
    if where == "middle":
        return n // 2 if n % 2 == 1 else None
    k = int(where)
    return k if k >= 0 else n + k


def _ok(order: tuple[str, ...], c: OrderConstraints) -> bool:
    idx = {x: i for i, x in enumerate(order)}
    n = len(order)
    if any(idx[x] != idx[y] + 1 for x, y in c.on):
        return False
    if any(idx[x] <= idx[y] for x, y in c.above):
        return False
    for x, where in c.at:
        lv = _level(n, where)
        if lv is None or not 0 <= lv < n or idx[x] != lv:
            return False
    for seq in c.sequences:
        pos = [idx[x] for x in seq]
        if any(b != a + 1 for a, b in pairwise(pos)):
            return False
    return True


def solve(c: OrderConstraints, limit: int = 8) -> list[tuple[str, ...]]:
    """Every order of ``c.items`` (bottom first) satisfying ``c``; at most ``limit`` items are searched."""
    if len(c.items) > limit:
        raise ValueError(f"too many items to order: {len(c.items)} > {limit}")
    return [p for p in permutations(c.items) if _ok(p, c)]


def undetermined(orders: list[tuple[str, ...]]) -> list[str]:
    """Items whose level differs between ``orders`` (what the instruction left open)."""
    if not orders:
        return []
    return [x for x in orders[0] if len({o.index(x) for o in orders}) > 1]
