"""Branch instrumentation for white-box path coverage (paper, supplementary: "Executability").

:func:`instrument` rewrites a *validated* program so that every branch records that it was taken, by
calling a marker ``__cam_cov__(k)`` (a name no validated program can spell, since names starting with
``__`` are rejected). The rewrite is pure AST work and deterministic: the control process computes the
branch table from the source, the sandbox worker computes the same table and runs the rewritten code.
No instrumented code is ever executed outside the worker.
"""

from __future__ import annotations

import ast
import copy
from dataclasses import dataclass

MARKER = "__cam_cov__"


@dataclass(frozen=True)
class Branch:
    """One branch arm of a monitor program.

    Attributes:
        id: index in the branch table (what the marker records).
        function: name of the enclosing function.
        line: source line of the branching construct.
        kind: ``entry`` (function entered), ``if-true``, ``if-false``, ``for-body``,
            ``ifexp-true`` or ``ifexp-false``.
    """

    id: int
    function: str
    line: int
    kind: str

    def describe(self) -> str:
        what = {
            "entry": "the function is never called",
            "if-true": "the 'if' condition is never true",
            "if-false": "the 'if' condition is never false",
            "for-body": "the 'for' loop body is never entered",
            "ifexp-true": "the conditional expression never takes its first value",
            "ifexp-false": "the conditional expression never takes its 'else' value",
        }[self.kind]
        return f"{self.function}, line {self.line}: {what}"


def _mark(k: int, lineno: int) -> ast.stmt:
    call = ast.Call(func=ast.Name(id=MARKER, ctx=ast.Load()), args=[ast.Constant(k)], keywords=[])
    stmt = ast.Expr(value=call, lineno=lineno, col_offset=0, end_lineno=lineno, end_col_offset=0)
    return ast.fix_missing_locations(stmt)


class _Instrumenter(ast.NodeTransformer):
    def __init__(self) -> None:
        self.branches: list[Branch] = []
        self.func_stack: list[str] = []

    def _new(self, line: int, kind: str) -> int:
        k = len(self.branches)
        self.branches.append(Branch(k, self.func_stack[-1] if self.func_stack else "<module>", line, kind))
        return k

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:
        self.func_stack.append(node.name)
        k = self._new(node.lineno, "entry")
        self.generic_visit(node)
        node.body.insert(0, _mark(k, node.lineno))
        self.func_stack.pop()
        return node

    def visit_If(self, node: ast.If) -> ast.AST:
        k_true = self._new(node.lineno, "if-true")
        k_false = self._new(node.lineno, "if-false")
        self.generic_visit(node)
        node.body.insert(0, _mark(k_true, node.lineno))
        node.orelse.insert(0, _mark(k_false, node.lineno))
        return node

    def visit_For(self, node: ast.For) -> ast.AST:
        k = self._new(node.lineno, "for-body")
        self.generic_visit(node)
        node.body.insert(0, _mark(k, node.lineno))
        return node

    def visit_IfExp(self, node: ast.IfExp) -> ast.AST:
        k_true = self._new(node.lineno, "ifexp-true")
        k_false = self._new(node.lineno, "ifexp-false")
        self.generic_visit(node)

        def wrap(k: int, value: ast.expr) -> ast.expr:
            call = ast.Call(func=ast.Name(id=MARKER, ctx=ast.Load()), args=[ast.Constant(k), value], keywords=[])
            return ast.fix_missing_locations(ast.copy_location(call, value))

        node.body = wrap(k_true, node.body)
        node.orelse = wrap(k_false, node.orelse)
        return node


def instrument(tree: ast.Module) -> tuple[ast.Module, list[Branch]]:
    """Return an instrumented copy of a validated module and its branch table (ids 0..n-1).

    Markers: function entry, both arms of every ``if``/``elif``/``else`` (an ``if`` without ``else``
    gets an implicit one, so falling through counts as a branch), every ``for`` body, and both arms of
    every conditional expression. Module-level code is not instrumented.
    """
    new = copy.deepcopy(tree)
    ins = _Instrumenter()
    new.body = [ins.visit(stmt) if isinstance(stmt, ast.FunctionDef) else stmt for stmt in new.body]
    return ast.fix_missing_locations(new), ins.branches
