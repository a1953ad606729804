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
        if "cli" in path.relative_to(PACKAGE).parts:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """pnmold module -> the pnmold modules it imports anywhere in its text (function-level imports
    too: a circle broken only by importing late is still a circle). ``from pkg import name`` counts
    as an import of ``pkg.name`` where that is a module, else of ``pkg``; a module's own package
    (``__init__``), which Python runs first, is not counted as its import."""
    paths = {_module_name(p): p for p in PACKAGE.rglob("*.py")}

    def resolve(name: str) -> str | None:
        while name and name not in paths:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets |= {resolve(a.name) for a in node.names if a.name.startswith("pnmold")}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1]
                                    + ([node.module] if node.module else []))
                if base.startswith("pnmold"):
                    targets |= {f"{base}.{a.name}" if f"{base}.{a.name}" in paths else resolve(base)
                                for a in node.names}
        graph[name] = {t for t in targets if t and t != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle_anywhere():
    assert _cycles(import_graph()) == []


def test_the_cycle_finder_finds_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_the_library_never_imports_the_command_line():
    graph = import_graph()
    offenders = [m for m, targets in graph.items()
                 if not m.startswith("pnmold.cli") and any(t.startswith("pnmold.cli") for t in targets)]
    assert offenders == []
    assert "pnmold.cli.build" in graph["pnmold.cli._main"]  # the walk sees the command line's imports


#: the rooms of pnmold from the bottom up (docs/layout.md): a room imports only rooms below it, so data
#: flow one way, design -> cad -> checks / mesh -> fem -> physics -> simulate / diagnose -> report
ROOMS = [
    ("pnmold.errors", "pnmold.version"),
    ("pnmold.fsutil",),
    ("pnmold.conventions", "pnmold.effects", "pnmold.frames", "pnmold.plots"),
    ("pnmold.recording",),
    ("pnmold.materials",),
    ("pnmold.design", "pnmold.track"),
    ("pnmold.cad", "pnmold.checks", "pnmold.tetmesh"),
    ("pnmold.mesh", "pnmold.fem"),
    ("pnmold.design_fe",),
    ("pnmold.physics", "pnmold.export"),
    ("pnmold.pneumatics",),
    ("pnmold.simulate", "pnmold.report"),
    ("pnmold.diagnose", "pnmold.pipeline"),
    ("pnmold.sweep",),
    ("pnmold.cli",),
    ("pnmold",),
]
RANK = {room: floor for floor, rooms in enumerate(ROOMS) for room in rooms}
#: where the physics lives: none of it may reach up to what orchestrates or reports it
PHYSICS = ("pnmold.fem", "pnmold.physics", "pnmold.pneumatics", "pnmold.materials", "pnmold.mesh", "pnmold.design_fe")
ABOVE_PHYSICS = ("pnmold.pipeline", "pnmold.simulate", "pnmold.report", "pnmold.diagnose", "pnmold.sweep",
                 "pnmold.cli")


def _room(module: str) -> str:
    return ".".join(module.split(".")[:2])


def test_every_module_lives_in_a_known_room():
    assert sorted({_room(m) for m in import_graph()} - set(RANK)) == []


def test_rooms_import_only_rooms_below_them():
    upward = sorted(f"{m} -> {t}" for m, targets in import_graph().items() for t in targets
                    if _room(m) != _room(t) and RANK[_room(t)] >= RANK[_room(m)])
    assert upward == []


def test_no_physics_package_reaches_up_to_the_pipeline_or_simulate():
    offenders = sorted(f"{m} -> {t}" for m, targets in import_graph().items() if _room(m) in PHYSICS
                       for t in targets if _room(t) in ABOVE_PHYSICS)
    assert offenders == []


def test_the_rank_check_sees_an_upward_arrow():
    assert RANK[_room("pnmold.fem.newton")] < RANK[_room("pnmold.simulate.dynamic")]
    assert RANK[_room("pnmold.pneumatics.law")] < RANK[_room("pnmold.pipeline")]


def test_at_most_thirteen_modules_at_the_top_of_the_package():
    assert len(list(PACKAGE.glob("*.py"))) <= 13, sorted(p.name for p in PACKAGE.glob("*.py"))


def test_no_module_over_450_lines():
    long = {str(p.relative_to(PACKAGE)): n for p in PACKAGE.rglob("*.py")
            if (n := len(p.read_text().splitlines())) > 450}
    assert long == {}


def _compiled(node: ast.AST) -> bool:
    """A numba kernel (``@nb.njit``, ``@njit(...)``): compiled code, one long loop by nature."""
    for d in getattr(node, "decorator_list", []):
        target = d.func if isinstance(d, ast.Call) else d
        if (getattr(target, "attr", None) or getattr(target, "id", None)) in ("njit", "jit"):
            return True
    return False


def long_functions(limit: int = 80) -> dict[str, int]:
    """``file:function`` -> lines, for every function over ``limit`` lines that is not a compiled kernel."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and not _compiled(node):
                lines = node.end_lineno - node.lineno + 1
                if lines > limit:
                    out[f"{path.relative_to(PACKAGE)}:{node.name}"] = lines
    return out


def test_no_function_over_80_lines_outside_compiled_kernels():
    assert long_functions() == {}


def test_the_length_check_sees_a_long_function():
    assert long_functions(limit=60)  # some functions are between 60 and 80 lines: the walk reaches them
