"""Perception and the painter never read the simulator: no ``sim`` import, and the non-oracle trackers
never touch ``Observation.object_poses``."""

from __future__ import annotations

import ast
from pathlib import Path

import code_as_monitor

PKG = Path(code_as_monitor.__file__).parent


def _imports(path: Path) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
    return out


def test_perception_and_painter_never_import_sim():
    files = sorted((PKG / "perception").rglob("*.py")) + sorted((PKG / "painter").rglob("*.py"))
    assert len(files) > 10
    bad = {str(f.relative_to(PKG)): m for f in files for m in _imports(f)
           if m == "code_as_monitor.sim" or m.startswith("code_as_monitor.sim.") or m == "pybullet"}
    assert not bad, bad


def test_only_the_oracle_tracker_reads_object_poses():
    trackers = sorted((PKG / "perception" / "trackers").glob("*.py"))
    readers = set()
    for f in trackers:
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr == "object_poses":
                readers.add(f.name)
    assert readers == {"sim.py"}, readers
