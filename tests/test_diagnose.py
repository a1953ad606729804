"""``pnmold diagnose`` on the reduced model: damaged recordings refused before anything is
written; concealed effects named on a small fixed subset of the blind benchmark."""

from __future__ import annotations

import pytest

from pnmold.cli import main
from tests.test_recording import DAMAGED

GOOD_PV = "# kind: pv\nvolume_ml,pressure_kpa\n0,0\n0.5,10\n1.0,20\n"
WITH_COLUMN = sorted(name for name, (_, _, column) in DAMAGED.items() if column is not None)


def test_at_least_eight_kinds_of_damage_name_a_column():
    assert len(WITH_COLUMN) >= 8


@pytest.mark.parametrize("name", sorted(DAMAGED))
def test_damaged_recording_is_refused_and_nothing_is_written(name, tmp_path, capsys):
    text, line, column = DAMAGED[name]
    good = tmp_path / "good.csv"
    good.write_text(GOOD_PV)
    bad = tmp_path / f"{name}.csv"
    bad.write_text(text)
    out_json, report = tmp_path / "d.json", tmp_path / "report"
    code = main(["diagnose", "fpn", str(good), str(bad), "--json", str(out_json), "--report", str(report)])
    err = capsys.readouterr().err
    assert code == 2
    assert f"{name}.csv" in err and f"line {line}" in err
    if column is not None:
        assert str(column) in err
    assert not out_json.exists() and not report.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["good.csv", f"{name}.csv"])


# -- a small fixed subset of the blind benchmark (data from the reduced model) -------------
SUBSET = [  # (id, effect, value, extras, modulus scale, orientation)
    ("null", None, 0.0, {}, 1.08, "chambers_up"),
    ("gravity", "gravity", 0.8, {}, 0.93, "chambers_up"),
    ("mullins", "mullins", 0.2, {}, 1.05, "horizontal"),
    ("visco", "viscoelasticity", 0.3, {"viscoelasticity.tau_s": 2.0}, 0.95, "chambers_up"),
]


@pytest.mark.slow
@pytest.mark.parametrize("case", SUBSET, ids=[c[0] for c in SUBSET])
def test_blind_subset_names_the_concealed_effect(case, tmp_path):
    from benchmarks.diagnose_blind import Case, diagnose_case, generate
    from pnmold.design import load_design
    from pnmold.physics.characterise import characterise

    cid, effect, value, extras, scale, orientation = case
    char = characterise(load_design("fpn"))
    p_max = 0.85 * (char.full_bend_pressure_kpa or char.max_pressure_kpa)
    generate(Case(cid, "fpn", effect, value, extras, scale, orientation, 2.0, p_max, 6.0, "rom", 11), tmp_path)
    assert "effect" not in (tmp_path / "bending.csv").read_text()  # no label in the data
    doc, seconds, err = diagnose_case(tmp_path, "fpn")
    assert doc is not None, err
    named = [m["effect"] for m in doc["missing_physics"]]
    if effect is None:
        assert named == [] and doc["unexplained"] is False
        return
    assert named[:1] == [effect]
    assert doc["missing_physics"][0]["parameters"][effect] == pytest.approx(value, rel=0.2)
    assert doc["fit"]["heldout_rmse_before"] >= 3 * doc["fit"]["heldout_rmse_after"]
    assert doc["mismatch"] and doc["mismatch"][0]["significance"] > 4


@pytest.mark.slow
def test_report_and_json_follow_the_contract(tmp_path):
    import json

    from benchmarks.diagnose_blind import Case, generate
    from pnmold.design import load_design
    from pnmold.physics.characterise import characterise

    char = characterise(load_design("fpn"))
    p_max = 0.85 * (char.full_bend_pressure_kpa or char.max_pressure_kpa)
    generate(Case("g", "fpn", "layer_compliance", 0.1, {}, 1.0, "horizontal", 2.0, p_max, 8.0, "rom", 5), tmp_path)
    out = tmp_path / "diag.json"
    code = main(["diagnose", "fpn", str(tmp_path / "bending.csv"), str(tmp_path / "pv.csv"), "--json", str(out),
                 "--report", str(tmp_path / "report"), "--quiet"])
    assert code == 0
    doc = json.loads(out.read_text())
    assert doc["schema"] == "pnmold.diagnosis/1"
    for key in ("design", "recordings", "baseline", "mismatch", "missing_physics", "unexplained", "fit"):
        assert key in doc, key
    assert set(doc["baseline"]) >= {"calibrated", "rmse", "heldout_rmse"}
    assert set(doc["fit"]) >= {"rmse_before", "rmse_after", "heldout_rmse_before", "heldout_rmse_after"}
    m = doc["missing_physics"][0]
    assert m["effect"] == "layer_compliance" and "explanation" in m and "uncertainty" in m
    assert "layer" in m["explanation"] and "held-out error fell" in m["explanation"]
    page = (tmp_path / "report" / "report.html").read_text()
    assert "data:image/png;base64," in page and "layer_compliance" in page
    assert (tmp_path / "report" / "fits.png").stat().st_size > 20_000


def test_a_designs_reference_is_what_the_build_report_names_it():
    """The diagnosis's ``design`` (:class:`pnmold.diagnose.DesignRef`) is the build report's entry, key
    for key in the same order; what a toy leaves unstated is left out."""
    import json

    from pnmold.design import load_design
    from pnmold.diagnose import DesignRef
    from pnmold.report.build_report import design_entry

    design = load_design("fpn")
    assert json.dumps(DesignRef.of(design).as_json()) == json.dumps(design_entry(design))
    assert json.dumps(DesignRef("toy", "0").as_json()) == json.dumps({"name": "toy", "digest": "0"})
    assert DesignRef("toy", "0", "toy rubber").as_json() == {"name": "toy", "digest": "0", "material": "toy rubber"}


def test_calibration_window_stays_inside_the_reduced_models_bounds():
    """A modulus found at (or a rounding past) the wide search's bound gives a window the
    reduced model accepts: a P-V recording of a much softer rig once ended in a DesignError."""
    from pnmold.diagnose.calibrate import WIDE, WINDOW, calibration_parameters
    from pnmold.physics.rom import CALIBRATION

    lo, hi = CALIBRATION["modulus_scale"][1]
    assert WIDE == (lo, hi)
    for nominal in (0.0194, lo, 1.0, hi, 60.0):
        m = calibration_parameters(nominal)[0]
        assert lo <= m.low <= m.start <= m.high <= hi
    assert calibration_parameters(1.0)[0].low == WINDOW[0] and calibration_parameters(1.0)[0].high == WINDOW[1]


@pytest.mark.parametrize(("settled", "said"), [(1.83, True), (1.62, False)])
def test_a_final_modulus_away_from_the_material_checks_is_said(settled, said):
    """The material check's estimate (effects off) leads the notes; when the effects moved the final
    modulus away from it, the value it settled at is said beside it, not left to the JSON."""
    from types import SimpleNamespace

    from pnmold.diagnose.calibrate import MaterialCheck, calibration_notes, calibration_parameters

    check = MaterialCheck(1.61, False, "The recordings need a rubber 1.61 times stiffer.")
    final = SimpleNamespace(fit=SimpleNamespace(values={"modulus_scale": settled}))
    notes = calibration_notes(final, calibration_parameters(1.61), check)
    assert notes[0] == check.message
    assert any(f"settled at {settled:.3g} x the design's" in n for n in notes) is said



def test_the_blind_benchmarks_random_designs_are_valid_files_in_every_library_rubber(tmp_path):
    """``diagnose_blind.py --designs random``: each drawn design is written as a design file that
    loads back to the same design (same digest), the library's rubbers in turn, so a diagnosis
    of it runs as a lab's own design file would."""
    from benchmarks.diagnose_blind import random_designs
    from benchmarks.fe_robust import draw_designs, material_sets
    from pnmold.design import digest, load_design
    from pnmold.materials.library import list_materials

    paths = random_designs(4, 7, tmp_path)
    rubbers = [m.name for m in list_materials()]
    drawn = draw_designs(4, 7)
    assert len(paths) == 4
    for i, (path, (_, sets)) in enumerate(zip(paths, drawn, strict=True)):
        again = load_design(path)
        rubber = rubbers[i % len(rubbers)]
        assert again.material.name == rubber
        assert digest(again) == digest(load_design("fpn", [*sets, *material_sets(rubber)]))
    assert {load_design(p).material.name for p in paths} == set(rubbers)
