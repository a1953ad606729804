"""pnmold as a user installs it: the wheel, in a fresh virtualenv, run from a folder outside the
checkout. The fresh venv borrows this venv's dependencies through a ``.pth`` file (no download),
and the wheel goes in with ``--no-deps``; the checkout itself is not importable there."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: what setuptools reads to build the wheel (caches and build folders left out)
SOURCES = ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "LICENSE", "pnmold", "templates", "docs")
_SKIP = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc", "*.egg-info")


def _run(argv: list, **kwargs) -> subprocess.CompletedProcess:
    done = subprocess.run([str(a) for a in argv], capture_output=True, text=True, **kwargs)
    assert done.returncode == 0, f"{argv[:4]} exited {done.returncode}:\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"
    return done


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built from a copy of the sources (building in the checkout would leave
    ``build/`` in it) by setuptools' PEP 517 backend as ``pip wheel --no-build-isolation`` calls
    it, in this venv (no download), every warning an error: no deprecated setting."""
    src = tmp_path_factory.mktemp("src")
    for name in SOURCES:
        (shutil.copytree(ROOT / name, src / name, ignore=_SKIP) if (ROOT / name).is_dir()
         else shutil.copy2(ROOT / name, src / name))
    dist = tmp_path_factory.mktemp("dist")
    backend = f"from setuptools import build_meta; build_meta.build_wheel({str(dist)!r})"
    _run([sys.executable, "-W", "error", "-c", backend], cwd=src)
    (found,) = dist.glob("pnmold-*.whl")
    return found


@pytest.fixture(scope="module")
def fresh(wheel, tmp_path_factory) -> Path:
    """A new venv with the wheel installed; this venv's site-packages on its path by a ``.pth``."""
    home = tmp_path_factory.mktemp("fresh") / "venv"
    venv.create(home, with_pip=False)
    python = home / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    site = Path(_run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
    ours = dict.fromkeys(sysconfig.get_paths()[k] for k in ("purelib", "platlib"))
    (site / "_pnmold_test_deps.pth").write_text("".join(f"{p}\n" for p in ours))
    _run([sys.executable, "-m", "pip", "--python", python, "install", "--no-deps", "--no-index", "--quiet", wheel])
    return home


def _env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PNMOLD_TEMPLATES", "PYTHONHOME")}


def test_the_wheel_ships_the_templates_as_they_are(wheel):
    with zipfile.ZipFile(wheel) as whl:
        shipped = {n.removeprefix("pnmold/templates/"): whl.read(n) for n in whl.namelist()
                   if n.startswith("pnmold/templates/")}
        assert any(n.endswith(".dist-info/licenses/LICENSE") for n in whl.namelist())
        meta = next(whl.read(n).decode() for n in whl.namelist() if n.endswith(".dist-info/METADATA"))
    ours = {p.relative_to(ROOT / "templates").as_posix(): p.read_bytes() for p in (ROOT / "templates").rglob("*.toml")}
    assert {"fpn.toml", "spn.toml", "sweeps/fig-s2a.toml"} <= set(ours)
    assert shipped == ours
    assert "License-Expression: MIT" in meta


def test_the_wheel_ships_the_manual_as_it_is(wheel):
    with zipfile.ZipFile(wheel) as whl:
        shipped = {n.removeprefix("pnmold/docs/"): whl.read(n) for n in whl.namelist() if n.startswith("pnmold/docs/")}
    ours = {p.relative_to(ROOT / "docs").as_posix(): p.read_bytes() for p in (ROOT / "docs").rglob("*.md")}
    assert {"index.md", "recording-format.md", "json-schemas.md"} <= set(ours)
    assert shipped == ours


@pytest.mark.slow
def test_every_help_reference_to_the_manual_opens_from_the_installed_package(fresh, tmp_path):
    """Each verb's --help names manual pages as `pnmold docs PAGE`; each opens from the fresh venv's package."""
    import re

    bindir = fresh / ("Scripts" if os.name == "nt" else "bin")
    helps = "".join(_run([bindir / "pnmold", *verb, "--help"], cwd=tmp_path, env=_env()).stdout
                    for verb in (["recording"], ["recording", "template"], ["material", "fit"], ["diagnose"],
                                 ["simulate"]))
    flat = re.sub(r"(?<=\w)-\s+(?=\w)", "-", re.sub(r"\s+", " ", helps))  # help text wraps lines, after hyphens too
    named = set(re.findall(r"pnmold docs ([a-z-]+)", flat))
    assert {"recording-format", "tensile-files", "json-schemas"} <= named
    package = Path(_run([bindir / "python", "-c", "import pnmold; print(pnmold.__file__)"], cwd=tmp_path,
                        env=_env()).stdout.strip()).parent
    for page in sorted(named):
        path = Path(_run([bindir / "pnmold", "docs", page, "--path"], cwd=tmp_path, env=_env()).stdout.strip())
        assert path == package / "docs" / f"{page}.md" and path.is_file()
        text = _run([bindir / "pnmold", "docs", page], cwd=tmp_path, env=_env()).stdout
        assert text == path.read_text(encoding="utf-8")


@pytest.mark.slow
def test_the_installed_wheel_builds_and_lists_templates_outside_the_checkout(fresh, tmp_path):
    bindir = fresh / ("Scripts" if os.name == "nt" else "bin")
    where = _run([bindir / "python", "-c", "import pnmold, pnmold.design as d; print(pnmold.__file__); "
                  "print(d.templates_dir())"], cwd=tmp_path, env=_env()).stdout.split()
    module, templates = (Path(p).resolve() for p in where)
    assert module.is_relative_to(fresh.resolve()), f"pnmold imported from {module}, not the fresh venv"
    assert templates == module.parent / "templates"
    listed = _run([bindir / "pnmold", "templates"], cwd=tmp_path, env=_env()).stdout
    assert {"fpn", "spn", "fig-s2a-h5"} <= {line.split()[0] for line in listed.splitlines() if line.strip()}
    _run([bindir / "pnmold", "build", "--no-fem", "--quiet"], cwd=tmp_path, env=_env())
    report = json.loads((tmp_path / "out" / "fpn" / "report.json").read_text())
    assert report["design"]["name"] == "fpn"
    assert all(c["passed"] is not False for c in report["checks"])
    slicer = [c for c in report["checks"] if c["id"].startswith("print.slicer.")]
    assert slicer and all(c["passed"] for c in slicer)  # the packaged PrusaSlicer profile was found
