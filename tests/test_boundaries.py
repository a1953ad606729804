"""House rules that keep the stages separable, checked in fresh interpreters."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "pnmold"


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize(("library", "allowed"), [
    ("cadquery", "cad/"), ("OCP", "cad/"), ("gmsh", "mesh.py")])
def test_only_its_own_stage_imports_a_kernel(library, allowed):
    offenders = [str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
                 if library in _imports(p) and not str(p.relative_to(PACKAGE)).startswith(allowed)]
    assert offenders == []


def test_importing_pnmold_and_its_design_loads_no_kernel():
    code = ("import sys, pnmold, pnmold.design, pnmold.pipeline, pnmold.cli; "
            "bad = [m for m in ('cadquery', 'OCP', 'gmsh') if m in sys.modules]; "
            "print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_no_print_in_the_library():
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        if path.name == "cli.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []
