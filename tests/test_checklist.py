"""The fabrication checklist: every step of the supplement, in a workable order, with
quantities that agree with report.json."""

from __future__ import annotations

import re

import pytest

from pnmold.cli import main
from pnmold.report.checklist import checklist_sections, render_html, render_markdown

# the supplement's steps, in the order they must come
ORDER = ["Print `print/mold_interior.stl`", "Print `print/mold_exterior.stl`", "Print `print/mold_bottom.stl`",
         "Turn the exterior mold over", "Degas", "Pour into the exterior mold", "Press the interior mold in",
         "Cure the top layer", "Demold: lift the interior mold", "Cut the paper",
         "Lay the paper flat on the bottom mold",
         "Pour over the paper", "set the cured top layer into it", "Cure the bonded actuator", "Elastosil E951",
         "Punch the inlet with a 2 mm biopsy punch", "tubing of 0.79 mm ID, 2.38 mm OD", "Leak test",
         "Clamp the top and bottom faces of the first", "Bending test", "Safety limit",
         "Pressure-volume test", "three cycles"]


@pytest.mark.parametrize("template", ["fpn", "spn"])
def test_every_step_in_order(built, template):
    result = built(template)
    text = render_markdown(result.design, checklist_sections(result.design, result.report))
    positions = [text.find(step) for step in ORDER]
    assert all(p >= 0 for p in positions), [s for s, p in zip(ORDER, positions, strict=True) if p < 0]
    assert positions == sorted(positions)
    assert text.count("- [ ] ") >= 25
    assert text == (result.out_dir / "checklist.md").read_text()


@pytest.mark.parametrize("template", ["fpn", "spn"])
def test_quantities_agree_with_the_report(built, template):
    result = built(template)
    report = result.report
    text = render_markdown(result.design, checklist_sections(result.design, report))
    for pour in report["pours"]:
        for key, unit in (("part_a_g", "g"), ("part_b_g", "g"), ("mix_g", "g"), ("volume_ml", "mL"), ("mass_g", "g")):
            value = pour[key]
            found = [float(x) for x in re.findall(rf"(\d+(?:\.\d+)?) {unit}\b", text)]
            assert any(abs(f - value) <= 1e-3 * value for f in found), (key, value)
    px, py = result.design.paper_size_mm
    assert f"{px:.1f} x {py:.1f} mm" in text


def test_html_prints_cleanly(built):
    result = built("fpn")
    sections = checklist_sections(result.design, result.report)
    page = render_html(result.design, sections)
    assert "@media print" in page and "page-break-inside:avoid" in page
    assert page.count("<li>") == render_markdown(result.design, sections).count("- [ ] ")


def test_checklist_command_writes_a_file(tmp_path, capsys):
    out = tmp_path / "fpn.html"
    assert main(["checklist", "fpn", "--format", "html", "--out", str(out)]) == 0
    assert out.read_text().startswith("<!doctype html>")
    assert main(["checklist", "spn"]) == 0
    assert "Fabrication checklist: spn" in capsys.readouterr().out


def test_the_clamp_step_says_how_much_of_the_body_to_hold(built):
    result = built("fpn")
    text = render_markdown(result.design, checklist_sections(result.design, result.report))
    assert "Clamp the top and bottom faces of the first 11.0 mm (the proximal chamber" in text
    held = result.design.replace("clamp", length_mm=20.0)
    assert "the first 20.0 mm (clamp.length_mm" in render_markdown(held, checklist_sections(held, result.report))
