"""The package's shape, checked from the code: no import circle, no module over 400 lines, the layering rule.

The import graph is built with ``ast`` from every ``.py`` under ``src/code_as_monitor`` (nothing is imported).
An edge ``a -> b`` means module ``a`` names module ``b`` in an ``import`` or ``from ... import`` statement;
``from pkg import name`` points at ``pkg.name`` when that is a module, else at ``pkg``. A package's
``__init__`` is a node like any other and gets an edge only where it is named (importing ``a.b.c`` also runs
``a.b``'s ``__init__``, but that implicit edge is left out: counting it would make every sibling import look
like a circle through the parent package).

Two kinds of edges:

- **load-time**: statements that run when the module is imported: at module level, in class bodies and in
  module-level ``if``/``try`` blocks. ``if TYPE_CHECKING:`` blocks never run and are left out.
- **deferred**: imports inside a function or lambda, run on the first call.

``importlib.import_module("a.b")`` and ``__import__("a.b")`` with a literal name are imports too.

A circle is a circle in *either* graph: the check runs on load-time plus deferred edges, so moving an import
into a function (or spelling it as a literal ``import_module``) does not hide a circle. The way out of a circle
is a registry that loads implementations by name (``importlib.import_module`` of a name looked up in a table,
as :func:`code_as_monitor.core.registry.build_lazily` and :mod:`code_as_monitor.vlm.kb.registry` do: not an
edge here), or the shared helpers moved into a module both sides import.

The layering rule: ``core``, ``geometry``, ``perception``, ``vlm``, ``painter``, ``monitor``, ``planning`` and
``agent`` never import ``sim`` or ``recordings`` (deferred imports included).

Run ``python tests/test_architecture.py`` for the full report (circles, long modules, layer breaks).
"""

from __future__ import annotations

import ast
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
PACKAGE = "code_as_monitor"
MAX_LINES = 400

LOWER_LAYERS = ("core", "geometry", "perception", "vlm", "painter", "monitor", "planning", "agent")
"""Packages that never import the simulator or the bag reader."""
FORBIDDEN_BELOW = ("sim", "recordings")


@dataclass
class Graph:
    """The package's modules and import edges (module names in dotted form)."""

    files: dict[str, Path] = field(default_factory=dict)
    packages: set[str] = field(default_factory=set)
    load: dict[str, set[str]] = field(default_factory=dict)
    deferred: dict[str, set[str]] = field(default_factory=dict)

    def all_edges(self) -> dict[str, set[str]]:
        return {m: self.load.get(m, set()) | self.deferred.get(m, set()) for m in self.files}


def module_name(path: Path, src: Path = SRC) -> str:
    parts = list(path.relative_to(src).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _literal_import(node: ast.AST) -> str | None:
    """The module of ``importlib.import_module("a.b")`` or ``__import__("a.b")`` with a literal name (an import
    by another spelling, so it counts); None for anything else (a registry's name from a table is no edge)."""
    if not (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)):
        return None
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
    return node.args[0].value if name in ("import_module", "__import__") else None


def _imports(tree: ast.Module) -> list[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement with whether it runs at load time (False: inside a function or lambda)."""
    out: list[tuple[ast.Import | ast.ImportFrom, bool]] = []

    def visit(node: ast.AST, at_load: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                for stmt in child.orelse:
                    visit_stmt(stmt, at_load)
                continue
            visit_stmt(child, at_load)

    def visit_stmt(child: ast.AST, at_load: bool) -> None:
        if isinstance(child, (ast.Import, ast.ImportFrom)):
            out.append((child, at_load))
        elif (literal := _literal_import(child)) is not None:
            out.append((ast.Import(names=[ast.alias(name=literal)]), at_load))
        inner = at_load and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        visit(child, inner)

    visit(tree, True)
    return out


def _targets(node: ast.Import | ast.ImportFrom, here: str, is_package: bool, modules: set[str]) -> set[str]:
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        base = node.module or ""
        if node.level:
            anchor = here.split(".") if is_package else here.split(".")[:-1]
            anchor = anchor[: len(anchor) - (node.level - 1)]
            base = ".".join(anchor + ([base] if base else []))
        names = []
        for alias in node.names:
            sub = f"{base}.{alias.name}"
            names.append(sub if sub in modules else base)
    out = set()
    for name in names:
        # ``import a.b.c`` for a name that is not a module (never in this package, but be safe): its longest module.
        while name and name not in modules:
            name = name.rpartition(".")[0]
        if name and name != here:
            out.add(name)
    return out


def build_graph(src: Path = SRC, package: str = PACKAGE) -> Graph:
    g = Graph()
    for path in sorted((src / package).rglob("*.py")):
        name = module_name(path, src)
        g.files[name] = path
        if path.name == "__init__.py":
            g.packages.add(name)
    modules = set(g.files)
    for name, path in g.files.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        g.load[name], g.deferred[name] = set(), set()
        for node, at_load in _imports(tree):
            targets = _targets(node, name, name in g.packages, modules)
            (g.load if at_load else g.deferred)[name].update(targets)
    return g


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan's algorithm), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def strong(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))
    for v in sorted(edges):
        if v not in index:
            strong(v)
    return sorted(out)


def long_modules(g: Graph, limit: int = MAX_LINES) -> dict[str, int]:
    counts = {m: len(p.read_text(encoding="utf-8").splitlines()) for m, p in g.files.items()}
    return {m: n for m, n in sorted(counts.items()) if n > limit}


def layer_breaks(g: Graph) -> list[tuple[str, str, str]]:
    """(importer, imported, "load" | "deferred") for every lower-layer module importing sim or recordings."""
    out = []
    for kind, edges in (("load", g.load), ("deferred", g.deferred)):
        for src, targets in edges.items():
            layer = src.split(".")[1] if src.count(".") else ""
            if layer not in LOWER_LAYERS:
                continue
            for t in sorted(targets):
                if t.split(".")[1:2] and t.split(".")[1] in FORBIDDEN_BELOW:
                    out.append((src, t, kind))
    return sorted(out)


GRAPH = build_graph()


def test_graph_sees_the_package():
    assert len(GRAPH.files) > 100
    assert "code_as_monitor.core.registry" in GRAPH.load["code_as_monitor.vlm.backend"]
    # a deferred import is recorded as deferred, not as a load-time edge
    assert any(GRAPH.deferred.values())


def test_no_import_circle_at_load_time():
    assert cycles(GRAPH.load) == []


def test_no_import_circle_counting_deferred_imports():
    assert cycles(GRAPH.all_edges()) == []


def test_no_module_over_400_lines():
    assert long_modules(GRAPH) == {}, f"modules over {MAX_LINES} lines"


def test_lower_layers_never_import_sim_or_recordings():
    assert layer_breaks(GRAPH) == []


DOC = ROOT / "docs" / "architecture.md"


def documented_layers(doc: Path = DOC) -> dict[str, int]:
    """Package -> layer number, from the table of section 2 of docs/architecture.md."""
    import re

    out = {}
    for line in doc.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^\| (\d+) \| ([^|]+) \|", line)
        if m:
            for name in re.findall(r"`([\w.]+)`", m.group(2)):
                out[name.removeprefix(f"{PACKAGE}.")] = int(m.group(1))
    return out


def _package_of(module: str) -> str:
    return module.split(".")[1] if module.count(".") else ""


def test_documented_layers_name_every_package():
    packages = {_package_of(m) for m in GRAPH.files} - {""}
    assert packages == set(documented_layers())


def test_imports_only_point_down_the_layers():
    """An import between two packages goes to a strictly lower layer of the documented table."""
    layer = documented_layers()
    up = [f"{a} -> {b}" for a, targets in GRAPH.all_edges().items() for b in sorted(targets)
          if _package_of(a) and _package_of(b) and _package_of(a) != _package_of(b)
          and layer[_package_of(b)] >= layer[_package_of(a)]]
    assert up == []


def test_paths_named_in_the_architecture_doc_exist():
    import re

    text = DOC.read_text(encoding="utf-8")
    named = set(re.findall(r"(?<![\w/.])((?:src|tests|benchmarks)/[\w/]+\.py)", text))
    packages = "|".join(documented_layers())
    named |= {f"src/{PACKAGE}/{p}" for p in re.findall(r"`((?:" + packages + r")/[\w/]+\.py)", text)}
    assert named, "the doc names no file?"
    missing = sorted(p for p in named if not (ROOT / p).is_file())
    assert missing == [], f"docs/architecture.md names files that do not exist: {missing}"


KB = "code_as_monitor.vlm.kb"
FAMILIES = f"{KB}.families"


def _registered_families() -> tuple[str, ...]:
    from code_as_monitor.vlm.kb.registry import FAMILY_MODULES

    return FAMILY_MODULES


def _family_module_of(module: str) -> str | None:
    """The registered family a module under ``families/`` belongs to: itself, or the family its name extends
    (``stack_goal`` -> ``stack``); None when it belongs to none."""
    short = module.rpartition(".")[2]
    if short in _registered_families():
        return short
    owners = [f for f in _registered_families() if short.startswith(f + "_")]
    return owners[0] if len(owners) == 1 else None


def _family_files() -> list[str]:
    return sorted(m for m in GRAPH.files if m.startswith(FAMILIES + "."))


def test_kb_every_family_module_is_registered_or_one_familys_helper():
    """A family is one module plus its line in ``registry.FAMILY_MODULES`` (a part of it kept in a module of its
    own is named ``<family>_<what>`` and belongs to that family only)."""
    unowned = [m for m in _family_files() if _family_module_of(m) is None]
    assert unowned == [], f"modules under vlm/kb/families/ that are no registered family nor one's helper: {unowned}"
    missing = [f for f in _registered_families() if f"{FAMILIES}.{f}" not in GRAPH.files]
    assert missing == [], f"registered in FAMILY_MODULES without a module: {missing}"


def test_kb_families_do_not_import_each_other():
    """What two families share lives in ``vlm/kb/shared`` (or the grammar), not in one of them."""
    crossings = []
    for m in _family_files():
        for target in sorted(GRAPH.all_edges()[m]):
            if target.startswith(FAMILIES + ".") and _family_module_of(target) != _family_module_of(m):
                crossings.append(f"{m} -> {target}")
    assert crossings == [], (f"a kb family imports another family ({crossings}); move what they share to "
                             f"vlm/kb/shared (the gripper's finger elements are in vlm.kb.shared.grip)")


def test_kb_families_are_loaded_by_name_only():
    """Nothing outside ``families/`` imports a family: the registry loads them by name, so a new family touches
    its module and one registration line."""
    importers = [f"{src} -> {t}" for src, targets in GRAPH.all_edges().items() if not src.startswith(FAMILIES)
                 for t in targets if t.startswith(FAMILIES + ".")]
    assert importers == []


@pytest.mark.parametrize("name", _registered_families())
def test_kb_family_module_holds_its_rules(name):
    """The family's rule (plan and recovery), thresholds and templates are its module's."""
    import importlib

    fam = importlib.import_module(f"{FAMILIES}.{name}").FAMILY
    assert fam.next_subgoal.__module__ == f"{FAMILIES}.{name}"
    assert fam.thresholds and fam.templates
    assert all(f.__module__.startswith((f"{FAMILIES}.{name}", f"{KB}.shared.")) for f in fam.templates.values())


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("import x.b\nimport os\nimport x.a\n", ({"x.b"}, set())),
        ("def f():\n    from x import b\n", (set(), {"x.b"})),
        ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import x.b\n", (set(), set())),
        ("class C:\n    from . import b\n", ({"x.b"}, set())),
        ("from .b import thing\n", ({"x.b"}, set())),
        ("try:\n    import x.b\nexcept ImportError:\n    pass\n", ({"x.b"}, set())),
        ("f = lambda: __import__('x.b')\n", (set(), {"x.b"})),
        ("import importlib\nM = importlib.import_module('x.b')\n", ({"x.b"}, set())),
        ("import importlib\nT = {'b': 'x.b'}\ndef f(n):\n    return importlib.import_module(T[n])\n", (set(), set())),
    ],
)
def test_graph_builder_on_small_packages(tmp_path, source, expected):
    pkg = tmp_path / "x"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text(source)
    (pkg / "b.py").write_text("")
    g = build_graph(tmp_path, "x")
    assert (g.load["x.a"], g.deferred["x.a"]) == expected


def test_cycle_finder():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def report(g: Graph) -> str:
    lines = [f"{len(g.files)} modules"]
    load_cycles, all_cycles = cycles(g.load), cycles(g.all_edges())
    lines.append(f"load-time circles: {len(load_cycles)}")
    lines += [f"  {' <-> '.join(c)}" for c in load_cycles]
    lines.append(f"circles counting deferred imports: {len(all_cycles)}")
    lines += [f"  {' <-> '.join(c)}" for c in all_cycles]
    over = long_modules(g)
    lines.append(f"modules over {MAX_LINES} lines: {len(over)}")
    lines += [f"  {m} {n}" for m, n in over.items()]
    breaks = layer_breaks(g)
    lines.append(f"lower layers importing sim/recordings: {len(breaks)}")
    lines += [f"  {a} -> {b} ({k})" for a, b, k in breaks]
    return "\n".join(lines)


if __name__ == "__main__":
    print(report(GRAPH))
