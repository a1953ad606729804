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


# -- a small fixed subset of the blind benchmark: recordings made by `pnmold simulate` with its defaults
# (the declared orientation's gravity on), from the template's reduced model (its shipped characterisation)
SUBSET = [  # (id, effect, value, extras, orientation)
    ("null", None, 0.0, {}, "chambers_up"),
    ("null-down", None, 0.0, {}, "chambers_down"),
    ("gravity", "gravity", 0.3, {}, "chambers_up"),
    ("mullins", "mullins", 0.2, {}, "horizontal"),
    ("visco", "viscoelasticity", 0.3, {"viscoelasticity.tau_s": 2.0}, "chambers_up"),
]


@pytest.mark.slow
@pytest.mark.parametrize("case", SUBSET, ids=[c[0] for c in SUBSET])
def test_blind_subset_names_the_concealed_effect(case, tmp_path):
    from benchmarks.diagnose_blind import Case, diagnose_case, generate, visible
    from pnmold.design import load_design
    from pnmold.physics.characterise import characterise

    cid, effect, value, extras, orientation = case
    char = characterise(load_design("fpn"))
    p_max = 0.85 * (char.full_bend_pressure_kpa or char.max_pressure_kpa)
    case = visible(Case(cid, "fpn", "", effect, value, extras, orientation, 2.0, p_max, 6.0, "rom", 11))
    generate(case, tmp_path)
    value = case.value
    text = (tmp_path / "bending.csv").read_text()
    assert "effect" not in text and "model" not in text and "design" not in text  # no label in the data
    assert f"# orientation: {orientation}" in text
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

    from benchmarks.diagnose_blind import Case, generate, visible
    from pnmold.design import load_design
    from pnmold.physics.characterise import characterise

    char = characterise(load_design("fpn"))
    p_max = 0.85 * (char.full_bend_pressure_kpa or char.max_pressure_kpa)
    # a compliance the model's form error does not hide (0.1 mm/N moves the fpn's tip by 0.8 % of its range)
    generate(visible(Case("g", "fpn", "", "layer_compliance", 0.1, {}, "chambers_up", 2.0, p_max, 8.0, "rom", 5)),
             tmp_path)
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


# -- the rig as declared, the nuisances, the rest rows ---------------------------------------------
def _simulated(tmp_path, name: str, *extra: str):
    """A bending recording of the fpn made by ``pnmold simulate`` with its defaults (chambers up, gravity on)."""
    path = tmp_path / f"{name}.csv"
    assert main(["simulate", "fpn", "--model", "rom", "--kind", "bending", "--recording", str(path), "-q", *extra]) == 0
    return path


def _diagnosed(path, *recordings) -> dict:
    import json

    out = path.with_suffix(".json")
    assert main(["diagnose", "fpn", str(path), *map(str, recordings), "--json", str(out), "-q"]) == 0
    return json.loads(out.read_text())


def test_the_rig_as_declared_is_the_starting_model(tmp_path):
    """A recording ``simulate`` makes with its defaults declares chambers up and carries Earth's gravity:
    nothing is missing. The same made without gravity but still labelled chambers up shows a weight other
    than the declared one: gravity is named, near 0 g, in those words."""
    declared = _diagnosed(_simulated(tmp_path, "declared"))
    assert declared["missing_physics"] == [] and declared["unexplained"] is False
    assert "the rig as the recordings declare it: bending chambers_up" in declared["summary"]
    weightless = _diagnosed(_simulated(tmp_path, "weightless", "--effects", "gravity=0"))
    named = weightless["missing_physics"]
    assert [m["effect"] for m in named] == ["gravity"]
    assert named[0]["parameters"]["gravity"] < 0.1
    assert "other than the rig declares" in named[0]["explanation"] and "declared 1 g" in named[0]["explanation"]


def _rewritten(path, name: str, change) -> object:
    """``path``'s recording with its columns and metadata changed by ``change(columns, metadata)``."""
    from pnmold.recording import read_recording, write_recording

    rec = read_recording(path)
    columns, meta = dict(rec.columns), dict(rec.metadata)
    change(columns, meta)
    meta.pop("pnmold-recording", None), meta.pop("kind", None)
    return write_recording(path.parent / f"{name}.csv", rec.kind, columns, meta)


def test_a_rest_tip_short_of_the_clamp_is_a_frame_question_not_physics(tmp_path):
    """The lab measured the tip from the clamp's edge, 10 mm out: the rest rows say so before anything is
    fitted, with the key that settles it; the recording does not state tip_origin, so it is judged from its
    rest rows and no physics is named for the offset."""
    def shift(columns, meta):
        columns["tip_x_mm"] = columns["tip_x_mm"] - 10.0

    doc = _diagnosed(_rewritten(_simulated(tmp_path, "r"), "short", shift))
    (check,) = doc["rest_check"]
    assert check["question"] == "free_length" and check["key"] == "tip_origin" and check["registered_at_rest"]
    assert check["distance_mm"] > check["tolerance_mm"]
    assert doc["summary"].startswith("The rest rows of") and "`tip_origin`" in doc["summary"]
    assert doc["missing_physics"] == []


def test_a_rest_sag_against_the_declared_orientation_is_an_orientation_question(tmp_path):
    def flip(columns, meta):
        meta["orientation"] = "chambers_down"

    doc = _diagnosed(_rewritten(_simulated(tmp_path, "r"), "flipped", flip))
    (check,) = doc["rest_check"]
    assert check["question"] == "orientation" and check["key"] == "orientation" and not check["registered_at_rest"]
    assert "`orientation`" in doc["summary"].split(". ")[1] or "`orientation`" in doc["summary"][:600]


@pytest.mark.parametrize(("hung", "rolls"), [("chambers_down", True), ("chambers_up", False)])
def test_a_horizontal_rest_off_toward_the_chambers_may_be_the_body_rolling(tmp_path, hung, rolls):
    """Declared horizontal, the tip rests off along z beyond every rest the body held on its side allows (its
    roll sags it a little toward +z): a declaration question either way; toward +z (the chambers' side) the
    words add that the body may roll further than the model's roll probe says, which the FE of the whole body
    would show."""
    def relabel(columns, meta):
        meta["orientation"] = "horizontal"

    doc = _diagnosed(_rewritten(_simulated(tmp_path, "r", "--orientation", hung), "side", relabel))
    (check,) = doc["rest_check"]
    assert check["question"] == "orientation" and check["distance_mm"] > check["tolerance_mm"]
    assert ("rolls" in check["words"] and "--orientation horizontal" in check["words"]) is rolls


def test_a_rest_that_agrees_raises_no_question(tmp_path):
    doc = _diagnosed(_simulated(tmp_path, "r"))
    (check,) = doc["rest_check"]
    assert check["question"] is None and check["distance_mm"] < check["tolerance_mm"]
    assert not doc["summary"].startswith("The rest rows")


def _rom_recording(tmp_path, name: str, calibration: dict, meta: dict, frame=None, noise_mm: float = 0.15):
    """The fpn's reduced model on a three-cycle ramp with ``calibration`` (a batch's scales), noise, and
    optionally seen through a camera ``frame`` (dx, dz, turn in degrees)."""
    import math

    import numpy as np

    from pnmold.design import load_design
    from pnmold.physics import Protocol, ReducedModel
    from pnmold.recording import write_recording

    ramp = Protocol.ramp("bending", 30.0, 2.0, 3, 2.0, meta.get("orientation", "chambers_up"))
    cols = ReducedModel.for_design(load_design("fpn")).run(ramp, {}, None, calibration)
    x, z = cols["tip_x_mm"], cols["tip_z_mm"]
    if frame is not None:
        dx, dz, turn = frame
        a = math.radians(turn)
        x, z = math.cos(a) * x - math.sin(a) * z + dx, math.sin(a) * x + math.cos(a) * z + dz
    rng = np.random.default_rng(7)
    return write_recording(tmp_path / f"{name}.csv", "bending",
                           {"pressure_kpa": ramp.pressure_kpa, "cycle": ramp.cycle, "phase": ramp.phase,
                            "time_s": ramp.times_s(), "tip_x_mm": x + rng.normal(0, noise_mm, x.size),
                            "tip_z_mm": z + rng.normal(0, noise_mm, z.size)}, {"rate_kpa_per_s": "2", **meta})


def test_a_batch_heavier_and_softer_than_the_library_is_calibrated_not_named(tmp_path):
    doc = _diagnosed(_rom_recording(tmp_path, "batch", {"modulus_scale": 0.94, "density_scale": 1.05},
                                    {"orientation": "chambers_up"}))
    assert doc["missing_physics"] == [] and doc["unexplained"] is False
    final = doc["calibration"]["final"]
    assert final["modulus_scale"] == pytest.approx(0.94, rel=0.02)
    assert final["density_scale"] == pytest.approx(1.05, rel=0.02)
    assert "its density x 1.05" in doc["summary"]


@pytest.mark.parametrize(("turn", "pinned"), [(4.0, False), (20.0, True)], ids=["level-enough", "turned"])
def test_a_camera_frame_is_registered_within_its_window_and_a_turn_beyond_it_is_said(turn, pinned, tmp_path):
    doc = _diagnosed(_rom_recording(tmp_path, "camera", {}, {"orientation": "chambers_up", "tip_origin": "camera"},
                                    frame=(15.0, -4.0, turn)))
    final = doc["calibration"]["final"]
    said = any("turn is pinned" in n for n in doc["calibration"]["notes"])
    assert said is pinned
    if not pinned:
        assert final["frame_dx_mm"] == pytest.approx(15.0, abs=1.0) and final["frame_rotation_deg"] == pytest.approx(
            turn, abs=0.5)
        assert doc["missing_physics"] == [] and not any("absorbs a misfit" in n for n in doc["calibration"]["notes"])
    else:
        assert final["frame_rotation_deg"] == pytest.approx(10.0, abs=0.1)
