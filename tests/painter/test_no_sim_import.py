"""The painter, the trackers and the geometry never read simulator poses: none of their modules imports ``sim``
(statically, anywhere in the file, including inside functions), and importing them all loads neither the
simulator package nor PyBullet."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import code_as_monitor

PKG = Path(code_as_monitor.__file__).parent
NO_SIM = ("core", "geometry", "perception", "painter", "monitor", "planning", "agent")


def _imports(path: Path, pkg: tuple[str, ...] | None = None) -> list[str]:
    """Every module name an ``import`` / ``from ... import`` in ``path`` names, relative ones resolved against
    the package ``pkg`` (default: the file's own package)."""
    tree = ast.parse(path.read_text(), str(path))
    if pkg is None:
        pkg = path.relative_to(PKG.parent).with_suffix("").parts[:-1]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join([*pkg[: len(pkg) - node.level + 1], *([base] if base else [])])
            out += [base] + [f"{base}.{a.name}" for a in node.names]
    return out


@pytest.mark.parametrize("layer", NO_SIM)
def test_no_module_of_the_layer_imports_sim(layer: str) -> None:
    files = sorted((PKG / layer).rglob("*.py"))
    assert files, layer
    bad = [f"{f.relative_to(PKG)}: {m}" for f in files for m in _imports(f) if _is_sim(m)]
    assert not bad, bad


def _is_sim(module: str) -> bool:
    return module == "code_as_monitor.sim" or module.startswith("code_as_monitor.sim.") or module == "pybullet"


def test_the_checker_sees_sim_imports_anywhere_in_a_file(tmp_path: Path) -> None:
    f = tmp_path / "probe.py"
    f.write_text("def f():\n    from ..sim.world import World\n\n"
                 "class C:\n    import pybullet\n    from code_as_monitor import sim\n")
    found = [m for m in _imports(f, ("code_as_monitor", "painter")) if _is_sim(m)]
    assert {"code_as_monitor.sim.world", "pybullet", "code_as_monitor.sim"} <= set(found)


def test_importing_the_perception_path_loads_no_simulator() -> None:
    layers = ("geometry", "painter", "perception")
    code = (
        "import sys, importlib, pkgutil\n"
        "import code_as_monitor\n"
        f"for layer in {layers!r}:\n"
        "    pkg = importlib.import_module('code_as_monitor.' + layer)\n"
        "    for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "        importlib.import_module(m.name)\n"
        "bad = sorted(m for m in sys.modules if m.startswith('code_as_monitor.sim') or m == 'pybullet')\n"
        "print(bad)\n"
        "sys.exit(1 if bad else 0)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
