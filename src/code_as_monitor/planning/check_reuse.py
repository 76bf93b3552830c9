"""Checks the coder already wrote, kept per constraint and renumbered for a later subgoal.

A stacking episode monitors the same constraint in several subgoals ("the green block is still on the red
block" while the blue block is picked, carried and placed); each subgoal numbers its elements afresh, so
the whole-program reuse of :class:`~code_as_monitor.planning.coder.MonitorCoder` (same request word for
word) does not find it. This module keeps every accepted ``check_<id>`` function under what it reads:

    the constraint (id, text, phase, thresholds, monotone parts) and, in order, the kind and owner of each
    element its ``element_ids`` name.

A later constraint with the same key gets the same function with its element subscripts renumbered
(``E[2]`` -> ``E[1]`` when the green block is element 1 now), and the coder asks the model only for the
constraints it has no function for. The combined program is validated as any other (static checks, path
coverage on the current state); a rejection falls back to asking for the whole program.

A function is kept only when renumbering it is exact: ``E`` and ``H`` appear only as ``E[<int>]`` /
``H[<int>]`` with an index among the constraint's element ids (``H.t`` too), and it reads no other
module-level name of its program (a helper or constant defined beside it). Anything else (an index
computed at run time, a monotone set read as ``[i for i in ids if i in E]``) is left to the model.
"""

from __future__ import annotations

import ast
import json
from dataclasses import dataclass

from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.elements import Element

REUSED_HEADER = "# checks accepted earlier in this episode for the same constraints, element ids renumbered"
"""The comment line above the reused functions of a combined program."""


def check_key(c: Constraint, ids: list[int], elements: dict[int, Element]) -> str:
    """What a check function depends on: the constraint's id, text, phase, thresholds and monotone parts, and
    the (kind, object, part) of each element it reads, in ``ids`` order (JSON, sorted keys)."""
    return json.dumps({
        "id": c.id, "text": c.text, "phase": c.phase.value,
        "thresholds": {k: float(v) for k, v in sorted(c.thresholds.items())},
        "monotone": sorted(c.monotone) if c.monotone else [],
        "elements": [[elements[i].kind.value, *elements[i].owner] for i in ids],
    }, sort_keys=True)


@dataclass(frozen=True)
class KeptCheck:
    """One accepted check: its function's source and the element ids it was written for (its constraint's
    ``element_ids`` in that subgoal, in order)."""

    source: str
    ids: tuple[int, ...]


class _Renumber(ast.NodeTransformer):
    """Rewrites ``E[k]`` / ``H[k]`` by ``mapping``; ``ok`` turns False on any other use of ``E`` or ``H``."""

    def __init__(self, mapping: dict[int, int]) -> None:
        self.mapping = mapping
        self.ok = True

    def visit_Subscript(self, node: ast.Subscript) -> ast.AST:
        if isinstance(node.value, ast.Name) and node.value.id in ("E", "H"):
            s = node.slice
            if (isinstance(s, ast.Constant) and type(s.value) is int and s.value in self.mapping
                    and isinstance(node.ctx, ast.Load)):
                node.slice = ast.copy_location(ast.Constant(self.mapping[s.value]), s)
                return node
            self.ok = False
            return node
        return self.generic_visit(node)

    def visit_Attribute(self, node: ast.Attribute) -> ast.AST:
        if isinstance(node.value, ast.Name) and node.value.id == "H" and node.attr == "t":
            return node
        return self.generic_visit(node)

    def visit_Name(self, node: ast.Name) -> ast.AST:
        if node.id in ("E", "H"):  # reached only outside E[k], H[k] and H.t
            self.ok = False
        return node


def renumber(fn_source: str, old: tuple[int, ...], new: list[int]) -> str | None:
    """``fn_source`` (one function) with its element subscripts mapped ``old[i] -> new[i]``; None when that is
    not exact (the lengths differ, an id repeats with two images, or ``E`` / ``H`` is used any other way)."""
    if len(old) != len(new):
        return None
    mapping: dict[int, int] = {}
    for a, b in zip(old, new):
        if mapping.setdefault(a, b) != b:
            return None
    tree = ast.parse(fn_source)
    if len(tree.body) != 1 or not isinstance(tree.body[0], ast.FunctionDef):
        return None
    fn = tree.body[0]
    args = [a.arg for a in fn.args.args]
    if len(args) != 3:
        return None
    # The contract's names are E, H, t; a function that renamed its arguments is renumbered through them.
    if args[:2] != ["E", "H"]:
        return None
    walker = _Renumber(mapping)
    fn = walker.visit(fn)
    if not walker.ok:
        return None
    return ast.unparse(ast.fix_missing_locations(fn))


def split_checks(source: str) -> dict[str, str]:
    """``check_<id>`` name -> its function's source, for the functions that read no other module-level name of
    ``source`` (no helper or constant defined beside them); {} when ``source`` does not parse."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return {}
    top: set[str] = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            top.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                top.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            top.update((a.asname or a.name).split(".")[0] for a in node.names)
    out: dict[str, str] = {}
    for node in tree.body:
        if not (isinstance(node, ast.FunctionDef) and node.name.startswith("check_")):
            continue
        used = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
        if used & (top - {node.name}):
            continue
        out[node.name] = ast.unparse(node)
    return out


def combine(asked: str | None, reused: dict[str, str]) -> str:
    """The program of a subgoal: the model's answer for the constraints asked (None: none were), then the
    reused functions (``check_<id>`` -> source) that the answer does not define itself."""
    defined: set[str] = set()
    if asked is not None:
        try:
            defined = {n.name for n in ast.parse(asked).body if isinstance(n, ast.FunctionDef)}
        except SyntaxError:
            defined = set()
    extra = [src for name, src in reused.items() if name not in defined]
    parts = [asked.rstrip()] if asked else []
    if extra:
        parts.append("\n\n".join([REUSED_HEADER, *extra]))
    return "\n\n".join(parts) + "\n"
