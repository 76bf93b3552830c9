"""The vlm package's shape: no import circles (function-level imports included), small modules, and kb task
families that register with one line each."""

from __future__ import annotations

import ast
from pathlib import Path

import code_as_monitor.vlm as vlm_pkg
from code_as_monitor.vlm.kb.registry import FAMILY_MODULES, all_templates, all_thresholds, families

ROOT = Path(vlm_pkg.__file__).parent
PKG = "code_as_monitor.vlm"


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = [p for p in rel.parts if p != "__init__"]
    return ".".join([PKG, *parts])


def _imports(path: Path, modules: set[str]) -> set[str]:
    """Every module of the vlm package that ``path`` imports, anywhere in its body (``from pkg import sub``
    depends on the submodule ``pkg.sub`` when there is one, else on ``pkg``)."""
    me = _module_name(path)
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = me.split(".")[: len(me.split(".")) - node.level + (1 if is_pkg else 0)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for a in node.names:
                out.add(f"{mod}.{a.name}" if f"{mod}.{a.name}" in modules else mod)
    return {m for m in out if m.startswith(PKG)}


def _graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph = {}
    for name, path in files.items():
        deps = set()
        for m in _imports(path, set(files)):
            while m and m not in files:
                m = m.rpartition(".")[0]
            if m and m != name:
                deps.add(m)
        graph[name] = deps
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for d in sorted(graph.get(n, ())):
            if state.get(d) == 1:
                return [*stack[stack.index(d):], d]
            if d not in state:
                found = visit(d)
                if found:
                    return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state:
            found = visit(n)
            if found:
                return found
    return None


def test_the_cycle_finder_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_vlm_has_no_import_circles():
    graph = _graph()
    assert graph.get(f"{PKG}.kb.families.stack")
    assert _cycle(graph) is None, " -> ".join(_cycle(graph) or [])


def test_vlm_modules_are_under_400_lines():
    long = {str(p.relative_to(ROOT)): n for p in ROOT.rglob("*.py") if (n := len(p.read_text().splitlines())) >= 400}
    assert not long, long


def test_every_registered_family_is_one_module_with_its_tables():
    fams = families()
    assert [f.name for f in fams] and len(fams) == len(FAMILY_MODULES)
    assert {f.task for f in fams} >= {"stack-in-order", "sweep-half", "rope-close-square", "slot-pen", "stow-book",
                                      "pour-tea", "open-drawer"}
    for f in fams:
        assert f.summary and f.example and f.templates, f.name
    # the merged tables hold every family's entries (names clash nowhere: merging raises otherwise)
    assert set().union(*(set(f.thresholds) for f in fams)) == set(all_thresholds())
    assert set().union(*(set(f.templates) for f in fams)) <= set(all_templates())
