"""Static validation of generated monitor programs: parse with ``ast`` and check an allow-list.

A monitor program is untrusted model output. Before it ever reaches the sandbox worker it must pass
:func:`validate_program`, which accepts only a small, explicit subset of Python:

* top level: ``def`` statements, constant assignments and a docstring;
* statements: ``def`` (no decorators), ``return``, ``if``/``elif``/``else``, ``for`` (any iterable; the
  sandbox deadline bounds the work), assignments, expression statements, ``pass``/``break``/``continue``;
* expressions: arithmetic, comparisons, boolean logic, conditional expressions, subscripts and slices,
  tuples/lists/dicts/sets, comprehensions, f-strings, constants and calls;
* formats: widths and precisions written in an f-string's spec, a literal ``format()`` spec or a printf-style
  string before ``%`` are at most :data:`~.formats.MAX_FORMAT_NUMBER` (no ``*``; :mod:`.formats`);
* names: the check arguments, names the program binds itself, a few safe builtins, ``np``, ``math`` and
  the geometry helpers (:data:`code_as_monitor.geometry.helpers.MONITOR_HELPERS`);
* attributes: allow-listed members of ``np``, ``np.linalg`` and ``math``, ``H.t``, and a short list of
  array/list/dict methods. No attribute name may start with ``_``; ``.format``/``.format_map`` (the
  ``"{0.__class__}".format(x)`` escape) are refused;
* calls: only to those namespace functions, the safe builtins and the program's own functions;
  no ``out=``, a ``dtype=`` (and ``.astype``) only naming a number or bool type literally, a few
  positional arguments at most to numpy methods (``.sum(axis)``, not ``.sum(axis, dtype)``), and
  ``np.ndarray`` only for ``isinstance``.

Everything else (imports, ``while``, ``lambda``, classes, ``try``, ``global``, ``:=``, ``yield`` ...) is
rejected with a message naming the construct and its line: that message goes back to the coder.
"""

from __future__ import annotations

import ast
import re

from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.errors import ProgramError
from code_as_monitor.geometry.helpers import MONITOR_HELPERS
from code_as_monitor.monitor.allowlist import (
    BANNED_NAMES,
    DTYPES,
    MATH_ALLOWED,
    METHOD_MAX_POSITIONAL,
    NAMESPACE,
    NP_ALLOWED,
    NP_LINALG_ALLOWED,
    SAFE_BUILTINS,
    VALUE_ATTRS,
)
from code_as_monitor.monitor.formats import format_errors

MAX_SOURCE_CHARS = 50_000
MAX_NODES = 5_000
MAX_DEPTH = 80
MAX_INT = 10**9
MAX_STR = 2_000
MAX_ERRORS = 12

CHECK_PARAMS = ("E", "H", "t")
"""The exact parameter list of every ``check_<id>`` function."""

_REJECTED: dict[type, str] = {
    ast.Import: "import statements are not allowed (np, math and the geometry helpers are already there)",
    ast.ImportFrom: "import statements are not allowed (np, math and the geometry helpers are already there)",
    ast.While: "'while' loops are not allowed; use 'for' over a range or a list",
    ast.Lambda: "lambda expressions are not allowed; define a function with 'def'",
    ast.ClassDef: "class definitions are not allowed",
    ast.Try: "'try' is not allowed: let errors surface, the sandbox reports them",
    ast.With: "'with' statements are not allowed",
    ast.Raise: "'raise' is not allowed: return (False, reason) instead",
    ast.Assert: "'assert' is not allowed: return (False, reason) instead",
    ast.Delete: "'del' is not allowed",
    ast.Global: "'global' is not allowed",
    ast.Nonlocal: "'nonlocal' is not allowed",
    ast.NamedExpr: "assignment expressions (:=) are not allowed; assign on a line of its own",
    ast.Yield: "generators ('yield') are not allowed; return a tuple",
    ast.YieldFrom: "generators ('yield from') are not allowed; return a tuple",
    ast.Await: "'await' is not allowed",
    ast.AsyncFunctionDef: "'async def' is not allowed",
    ast.AsyncFor: "'async for' is not allowed",
    ast.AsyncWith: "'async with' is not allowed",
    ast.Match: "'match' statements are not allowed; use if/elif",
}
if hasattr(ast, "TryStar"):
    _REJECTED[ast.TryStar] = _REJECTED[ast.Try]

_ALLOWED_NODES: tuple[type, ...] = (
    ast.Module, ast.FunctionDef, ast.Return, ast.Assign, ast.AugAssign, ast.For, ast.If, ast.Expr,
    ast.Pass, ast.Break, ast.Continue,
    ast.BoolOp, ast.BinOp, ast.UnaryOp, ast.IfExp, ast.Dict, ast.Set, ast.ListComp, ast.SetComp,
    ast.DictComp, ast.GeneratorExp, ast.Compare, ast.Call, ast.FormattedValue, ast.JoinedStr, ast.Constant,
    ast.Attribute, ast.Subscript, ast.Starred, ast.Name, ast.List, ast.Tuple, ast.Slice,
    ast.arguments, ast.arg, ast.keyword, ast.comprehension,
    ast.boolop, ast.operator, ast.unaryop, ast.cmpop, ast.Load, ast.Store,
)
_PARTS_OF_REJECTED: tuple[type, ...] = (ast.ExceptHandler, ast.withitem, ast.alias, ast.match_case)


def _describe(node: ast.AST) -> str:
    return type(node).__name__


class _StripAnnotations(ast.NodeTransformer):
    """Drop annotations (never evaluated, never checked) and turn ``x: T = v`` into ``x = v``."""

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:
        node.returns = None
        for a in [*node.args.posonlyargs, *node.args.args, *node.args.kwonlyargs,
                  node.args.vararg, node.args.kwarg]:
            if a is not None:
                a.annotation = None
        self.generic_visit(node)
        return node

    def visit_AnnAssign(self, node: ast.AnnAssign) -> ast.AST:
        if node.value is None:
            return ast.copy_location(ast.Pass(), node)
        return ast.copy_location(ast.Assign(targets=[node.target], value=node.value), node)


def _size_and_depth(tree: ast.AST) -> tuple[int, int]:
    """Node count and nesting depth, iteratively (a deeply nested program must not blow the stack)."""
    count, deepest = 0, 0
    stack: list[tuple[ast.AST, int]] = [(tree, 1)]
    while stack:
        node, d = stack.pop()
        count += 1
        deepest = max(deepest, d)
        stack.extend((child, d + 1) for child in ast.iter_child_nodes(node))
    return count, deepest


def _bound_names(tree: ast.Module) -> tuple[set[str], set[str]]:
    """(all names the program binds anywhere, names of the functions it defines)."""
    bound: set[str] = set()
    funcs: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef):
            funcs.add(node.name)
            bound.add(node.name)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            bound.add(node.id)
    return bound, funcs


def _static_dtype(node: ast.AST) -> bool:
    """A dtype named literally: ``float``, ``np.float64``, ``"float64"`` ... (see ``allowlist.DTYPES``)."""
    if isinstance(node, ast.Name):
        return node.id in ("float", "int", "bool", "complex")
    if isinstance(node, ast.Attribute):
        return isinstance(node.value, ast.Name) and node.value.id == "np" and node.attr in DTYPES
    return isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in DTYPES


def _root_name(node: ast.AST) -> str | None:
    while isinstance(node, ast.Subscript | ast.Attribute | ast.Starred):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


class _Checker(ast.NodeVisitor):
    """Collects every violation of the allow-list with its line number."""

    def __init__(self, bound: set[str], funcs: set[str]) -> None:
        self.bound = bound
        self.funcs = funcs
        self.errors: list[str] = []

    def error(self, node: ast.AST, msg: str) -> None:
        self.errors.append(f"line {getattr(node, 'lineno', '?')}: {msg}")

    def generic_visit(self, node: ast.AST) -> None:
        if type(node) in _REJECTED:
            self.error(node, _REJECTED[type(node)])
            if isinstance(node, ast.Import | ast.ImportFrom):
                return
        elif isinstance(node, _PARTS_OF_REJECTED):
            pass  # the statement it belongs to is reported already
        elif not isinstance(node, _ALLOWED_NODES):
            self.error(node, f"{_describe(node)} is not allowed in a monitor program")
        for why in format_errors(node):  # widths and precisions written in a format (:mod:`.formats`)
            self.error(node, why)
        super().generic_visit(node)  # keep going: the coder gets every problem at once

    # --- statements -------------------------------------------------------------------------------
    def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
        if node.decorator_list:
            self.error(node, f"decorators are not allowed (function {node.name!r})")
        self._check_binding(node, node.name)
        self.generic_visit(node)

    def visit_arg(self, node: ast.arg) -> None:
        self._check_binding(node, node.arg)

    def visit_Assign(self, node: ast.Assign) -> None:
        for target in node.targets:
            self._check_store_target(target)
        self.generic_visit(node)

    def visit_AugAssign(self, node: ast.AugAssign) -> None:
        self._check_store_target(node.target)
        self.generic_visit(node)

    def visit_For(self, node: ast.For) -> None:
        self._check_store_target(node.target)
        self.generic_visit(node)

    def _check_store_target(self, target: ast.AST) -> None:
        if isinstance(target, ast.Tuple | ast.List):
            for elt in target.elts:
                self._check_store_target(elt)
        elif isinstance(target, ast.Attribute):
            self.error(target, f"assigning to an attribute ('.{target.attr}') is not allowed")
        elif isinstance(target, ast.Subscript) and _root_name(target) in ("E", "H"):
            self.error(target, f"the program must not modify its input {_root_name(target)}")

    # --- names, attributes, calls -----------------------------------------------------------------
    def _check_binding(self, node: ast.AST, name: str) -> None:
        if name in BANNED_NAMES or name.startswith("__"):
            self.error(node, f"the name {name!r} is not allowed")
        elif name in NAMESPACE or name in SAFE_BUILTINS:
            self.error(node, f"binding {name!r} shadows the namespace's {name}; use another name")

    def visit_Name(self, node: ast.Name) -> None:
        name = node.id
        if isinstance(node.ctx, ast.Store):
            self._check_binding(node, name)
        elif name in BANNED_NAMES or name.startswith("__"):
            self.error(node, f"the name {name!r} is not allowed")
        elif name not in self.bound and name not in SAFE_BUILTINS and name not in NAMESPACE:
            self.error(node, f"unknown name {name!r} (available: E, H, t, np, math, the geometry helpers, "
                             "a few builtins and the program's own names)")
        elif not isinstance(node.ctx, ast.Load | ast.Store):
            self.error(node, f"{_describe(node.ctx)} of {name!r} is not allowed")

    def visit_Attribute(self, node: ast.Attribute) -> None:
        attr = node.attr
        base = node.value
        if not isinstance(node.ctx, ast.Load):
            self.error(node, f"assigning to an attribute ('.{attr}') is not allowed")
        elif attr.startswith("_"):
            self.error(node, f"attribute names starting with '_' are not allowed ('.{attr}')")
        elif attr in ("format", "format_map"):
            self.error(node, f"'.{attr}' is not allowed (str.format can reach attributes); use an f-string")
        elif isinstance(base, ast.Name) and base.id == "np":
            if attr not in NP_ALLOWED:
                self.error(node, f"np.{attr} is not allowed in a monitor program")
        elif isinstance(base, ast.Attribute) and base.attr == "linalg" and _root_name(base) == "np":
            if attr not in NP_LINALG_ALLOWED:
                self.error(node, f"np.linalg.{attr} is not allowed in a monitor program")
        elif isinstance(base, ast.Name) and base.id == "math":
            if attr not in MATH_ALLOWED:
                self.error(node, f"math.{attr} is not allowed in a monitor program")
        elif isinstance(base, ast.Name) and base.id == "H":
            if attr != "t":
                self.error(node, f"H has no attribute '.{attr}' (only H.t and H[i])")
        elif attr not in VALUE_ATTRS:
            self.error(node, f"the attribute or method '.{attr}' is not allowed in a monitor program")
        self.generic_visit(node)

    def visit_Call(self, node: ast.Call) -> None:
        func = node.func
        if isinstance(func, ast.Name):
            name = func.id
            ok = name in SAFE_BUILTINS or name in MONITOR_HELPERS or name in self.funcs
            if not ok and name not in BANNED_NAMES and not name.startswith("__") and name in self.bound:
                self.error(node, f"calling {name!r} is not allowed: only np, math, the geometry helpers, "
                                 "safe builtins and the program's own functions may be called")
        elif not isinstance(func, ast.Attribute):
            self.error(node, "a call must name its function directly (np.f, math.f, a helper or a def)")
        else:
            self._check_method_call(node, func)
        for kw in node.keywords:
            if kw.arg == "out":
                self.error(node, "'out=' is not allowed in a monitor program; use the returned value")
            elif kw.arg == "dtype" and not _static_dtype(kw.value):
                self.error(node, f"dtype {ast.unparse(kw.value)!r} is not allowed: use float, int, bool or "
                                 "np.float64/np.int64/np.bool_")
        self.generic_visit(node)

    def _check_method_call(self, node: ast.Call, func: ast.Attribute) -> None:
        if isinstance(func.value, ast.Name) and func.value.id == "np" and func.attr == "ndarray":
            self.error(node, "np.ndarray(...) cannot be called (it builds arrays over raw buffers); use "
                             "np.array or np.zeros (isinstance(x, np.ndarray) is fine)")
            return
        if isinstance(func.value, ast.Name) and func.value.id in ("np", "math", "H"):
            return
        limit = METHOD_MAX_POSITIONAL.get(func.attr)
        if limit is not None and len(node.args) > limit:
            self.error(node, f"'.{func.attr}(...)' takes at most {limit} positional argument(s) in a monitor "
                             "program; pass the others by keyword")
        if func.attr == "astype" and (len(node.args) != 1 or not _static_dtype(node.args[0])):
            self.error(node, "'.astype(...)' needs one dtype: float, int, bool or np.float64/np.int64/np.bool_")

    # --- constants and f-strings ------------------------------------------------------------------
    def visit_Constant(self, node: ast.Constant) -> None:
        v = node.value
        if isinstance(v, bytes):
            self.error(node, "bytes literals are not allowed")
        elif isinstance(v, int) and not isinstance(v, bool) and abs(v) > MAX_INT:
            self.error(node, f"integer literal too large (|x| > {MAX_INT})")
        elif isinstance(v, str) and len(v) > MAX_STR:
            self.error(node, f"string literal too long ({len(v)} > {MAX_STR} characters)")

    def visit_comprehension(self, node: ast.comprehension) -> None:
        if node.is_async:
            self.error(node.target, "async comprehensions are not allowed")
        self.generic_visit(node)


def _is_docstring(stmt: ast.stmt) -> bool:
    return isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant) and isinstance(stmt.value.value, str)


def _check_structure(tree: ast.Module, constraints: list[Constraint], errors: list[str]) -> None:
    """Top level: only defs, constant assignments and a docstring; exactly the expected check functions."""
    defs: dict[str, ast.FunctionDef] = {}
    for stmt in tree.body:
        if isinstance(stmt, ast.FunctionDef):
            if stmt.name in defs:
                errors.append(f"line {stmt.lineno}: function {stmt.name!r} is defined twice")
            defs[stmt.name] = stmt
        elif isinstance(stmt, ast.Assign) or _is_docstring(stmt):
            continue
        elif type(stmt) not in _REJECTED:  # those get their own message from the checker
            errors.append(f"line {stmt.lineno}: only 'def' statements and constant assignments are allowed "
                          f"at the top level, not {_describe(stmt)}")
    wanted = [c.function_name for c in constraints]
    for name in wanted:
        if name not in defs:
            errors.append(f"missing check function: def {name}(E, H, t)")
            continue
        a = defs[name].args
        params = [p.arg for p in a.args]
        if a.posonlyargs or a.vararg or a.kwonlyargs or a.kwarg or a.defaults or tuple(params) != CHECK_PARAMS:
            errors.append(f"line {defs[name].lineno}: {name} must have the signature (E, H, t), "
                          f"got ({', '.join(params)}{', ...' if a.vararg or a.kwarg or a.kwonlyargs else ''})")
    for name, node in defs.items():
        if name.startswith("check_") and name not in wanted:
            ids = ", ".join(c.id for c in constraints) or "(none)"
            errors.append(f"line {node.lineno}: extra check function {name!r}: no constraint has that id "
                          f"(constraint ids: {ids})")


def _sorted_unique(errors: list[str]) -> list[str]:
    """Errors by line number (stable), duplicates dropped."""
    def line(e: str) -> int:
        m = re.match(r"line (\d+):", e)
        return int(m.group(1)) if m else 0

    return sorted(dict.fromkeys(errors), key=line)


def validate_program(source: str, constraints: list[Constraint]) -> ast.Module:
    """Parse and check a monitor program against the allow-list.

    Args:
        source: the generated Python source.
        constraints: the subgoal's constraints; the program must define exactly one
            ``check_<id>(E, H, t)`` per constraint (other helper functions are fine).
    Returns:
        The validated module with annotations stripped: what the sandbox worker compiles.
    Raises:
        ProgramError: listing every violation with its line (what goes back to the coder).
    """
    if not isinstance(source, str):
        raise ProgramError(f"monitor program must be a str, got {type(source).__name__}")
    if len(source) > MAX_SOURCE_CHARS:
        raise ProgramError(f"monitor program too long ({len(source)} > {MAX_SOURCE_CHARS} characters)")
    try:
        tree = ast.parse(source, filename="<monitor>", mode="exec")
    except SyntaxError as exc:
        raise ProgramError(f"monitor program rejected: line {exc.lineno}: syntax error: {exc.msg}") from None
    except (RecursionError, MemoryError, ValueError) as exc:
        raise ProgramError(f"monitor program rejected: cannot parse ({type(exc).__name__})") from None
    n_nodes, depth = _size_and_depth(tree)
    if n_nodes > MAX_NODES:
        raise ProgramError(f"monitor program rejected: too large ({n_nodes} syntax nodes > {MAX_NODES})")
    if depth > MAX_DEPTH:
        raise ProgramError(f"monitor program rejected: nested too deeply (depth {depth} > {MAX_DEPTH})")
    tree = _StripAnnotations().visit(tree)
    errors: list[str] = []
    _check_structure(tree, constraints, errors)
    bound, funcs = _bound_names(tree)
    checker = _Checker(bound, funcs)
    checker.visit(tree)
    errors = _sorted_unique(checker.errors) + errors
    if errors:
        shown = errors[:MAX_ERRORS]
        more = f"\n  ... and {len(errors) - MAX_ERRORS} more" if len(errors) > MAX_ERRORS else ""
        raise ProgramError("monitor program rejected:\n  " + "\n  ".join(shown) + more)
    return ast.fix_missing_locations(tree)
