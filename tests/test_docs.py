"""The docs users get (``docs/``): generated parts as the generator writes them, examples that
read, every JSON key the code writes described, and the help and README pointing to them."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import pytest

from pnmold.cli import main
from pnmold.cli._main import make_parser

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _generator():
    spec = importlib.util.spec_from_file_location("write_docs", ROOT / "scripts" / "write_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_committed_docs_are_what_the_generator_writes():
    stale = [p.name for p, text in _generator().documents().items() if p.read_text(encoding="utf-8") != text]
    assert stale == [], "run: .venv/bin/python scripts/write_docs.py"


def test_design_fields_lists_every_field_with_its_default():
    from dataclasses import fields

    from pnmold.design import SECTIONS

    text = (DOCS / "design-fields.md").read_text()
    for section, cls in SECTIONS.items():
        for f in fields(cls):
            row = next(line for line in text.splitlines() if line.startswith(f"| `{section}.{f.name}` |"))
            default = json.dumps(f.default) if isinstance(f.default, str) else repr(f.default)
            assert f"| `{default}` |" in row, row


def _examples(name: str) -> list[str]:
    return re.findall(r"```csv\n(.*?)```", (DOCS / name).read_text(), re.S)


def test_every_recording_example_reads(tmp_path):
    from pnmold.recording import read_recording

    examples = _examples("recording-format.md")
    kinds = []
    for i, text in enumerate(examples):
        path = tmp_path / f"example{i}.csv"
        path.write_text(text)
        kinds.append(read_recording(path).kind)
    assert kinds == ["bending", "pv", "force", "step"]
    pv = read_recording(tmp_path / "example1.csv")
    assert set(pv.conversions) == {"volume_ml", "pressure_kpa", "rate_kpa_per_s"}


def test_every_tensile_example_reads(tmp_path):
    from pnmold.materials import read_tensile

    examples = _examples("tensile-files.md")
    assert len(examples) == 2
    for i, text in enumerate(examples):
        path = tmp_path / f"example{i}.csv"
        path.write_text(text)
        assert len(read_tensile(path).strain) == 4


def _keys(doc, depth: int = 0) -> set[str]:
    """The keys of a JSON document that name fields (not data: part names, series, effects...)."""
    data_maps = {"parts", "versions", "slicer", "timings_s", "noise", "noise_parts", "calibrated", "parameters",
                 "uncertainty", "effects", "series", "variants", "conversions", "window", "solver", "model_info",
                 "probe", "final"}
    out = set()
    if isinstance(doc, dict):
        for key, value in doc.items():
            out.add(key)
            if key not in data_maps and depth < 2:
                out |= _keys(value, depth + 1)
    elif isinstance(doc, list) and doc and isinstance(doc[0], dict):
        out |= _keys(doc[0], depth)
    return out


def _undocumented(doc: dict) -> list[str]:
    text = (DOCS / "json-schemas.md").read_text()
    return sorted(k for k in _keys(doc) if f"`{k}`" not in text)


def test_the_characterisation_keys_are_documented():
    bundled = sorted((ROOT / "pnmold" / "data" / "characterisations").glob("*.json"))
    assert bundled
    doc = json.loads(bundled[0].read_text())
    assert doc["format"] == "pnmold.characterisation/1"
    assert _undocumented(doc) == []


@pytest.mark.slow
def test_the_simulation_and_diagnosis_keys_are_documented(tmp_path):
    design = "fig-s2a-h5"  # its characterisation ships with pnmold: no FE
    rec, sim, diag = tmp_path / "b.csv", tmp_path / "sim.json", tmp_path / "diag.json"
    assert main(["-q", "simulate", design, "--model", "rom", "--cycles", "2", "--rate-kpa-per-s", "2",
                 "--recording", str(rec), "--json", str(sim), "--noise-mm", "0.3", "--seed", "1"]) == 0
    assert main(["-q", "diagnose", design, str(rec), "--json", str(diag)]) == 0
    for path in (sim, diag):
        doc = json.loads(path.read_text())
        assert _undocumented(doc) == [], doc["schema"]


@pytest.mark.slow
def test_the_build_report_keys_are_documented(built):
    assert _undocumented(built("fpn").report) == []


@pytest.mark.parametrize(("argv", "pages"), [
    (["diagnose", "--help"], ["recording-format", "json-schemas"]),
    (["simulate", "--help"], ["recording-format", "json-schemas"]),
    (["material", "fit", "--help"], ["tensile-files"]),
    (["recording", "template", "--help"], ["recording-format"]),
], ids=["diagnose", "simulate", "material-fit", "recording-template"])
def test_help_points_to_the_manual_not_to_the_contracts(argv, pages, capsys):
    assert main(argv) == 0
    out = re.sub(r"(?<=\w)-\s+(?=\w)", "-", " ".join(capsys.readouterr().out.split()))  # argparse wraps lines
    for page in pages:
        assert f"pnmold docs {page}" in out and (DOCS / f"{page}.md").is_file()
    assert "CONTRACTS" not in out


def test_pnmold_docs_lists_the_pages_and_prints_one(capsys):
    assert main(["docs"]) == 0
    listed = {line.split()[0] for line in capsys.readouterr().out.splitlines() if line.strip()}
    assert {p.stem for p in DOCS.glob("*.md")} <= listed
    assert main(["docs", "recording-format"]) == 0
    assert capsys.readouterr().out == (DOCS / "recording-format.md").read_text(encoding="utf-8")
    assert main(["docs", "no-such-page"]) == 2
    assert "recording-format" in capsys.readouterr().err  # the refusal lists the pages


#: files users have: the package, the README and the manual; what the project keeps for itself is not cited
_CITED = re.compile(r"docs/([A-Za-z0-9_-]+\.md)")
_INTERNAL = ("CONTRACTS.md", "DIAGNOSE.md", "FEM_NOTES", "../shared")


def _user_texts() -> dict[str, str]:
    files = [*(ROOT / "pnmold").rglob("*.py"), ROOT / "README.md", *DOCS.glob("*.md"),
             *(ROOT / "pnmold" / "data").glob("*.ini")]
    return {str(p.relative_to(ROOT)): p.read_text(encoding="utf-8") for p in files}


def test_every_document_the_code_and_docs_cite_exists():
    missing = sorted({f"{name}: docs/{doc}" for name, text in _user_texts().items() for doc in _CITED.findall(text)
                      if not (DOCS / doc).is_file()})
    assert missing == []


def test_nothing_users_read_cites_the_projects_internal_notes():
    cited = sorted(f"{name}: {word}" for name, text in _user_texts().items() for word in _INTERNAL if word in text)
    assert cited == []


def test_no_help_text_mentions_the_contracts():
    parser = make_parser()
    texts = [parser.description or ""]
    for action in parser._subparsers._group_actions:
        for sub in action.choices.values():
            texts.append(sub.description or "")
            texts += [a.help or "" for a in sub._actions]
    assert not [t for t in texts if "CONTRACTS" in t]


def test_the_readme_points_to_the_manual():
    text = (ROOT / "README.md").read_text()
    linked = re.findall(r"\]\((docs/[^)#]+)\)", text)
    assert "docs/index.md" in linked
    assert [target for target in linked if not (ROOT / target).is_file()] == []


def test_links_between_docs_resolve():
    for page in DOCS.glob("*.md"):
        for target in re.findall(r"\]\(([^)#:]+)\)", page.read_text()):
            assert (page.parent / target).is_file(), f"{page.name}: {target}"


def _python_snippets() -> list[tuple[str, str]]:
    """Every ```python block of the README and the manual, as (where, code)."""
    out = []
    for path in [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]:
        for i, code in enumerate(re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), re.S)):
            out.append((f"{path.name}#{i + 1}", code))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("code", [c for _, c in _python_snippets()], ids=[w for w, _ in _python_snippets()])
def test_every_python_snippet_of_the_readme_and_the_manual_runs(code, tmp_path):
    """Each snippet runs as a user would paste it: a fresh interpreter, an empty working folder."""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]


def test_the_manual_has_python_snippets_to_run():
    assert len(_python_snippets()) >= 2
