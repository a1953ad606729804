"""The design's stated dimensional uncertainty as a floor under a diagnosis's noise
(``pnmold/physics/uncertainty.py``): on made-up FE curves with known answers (no FE here), and the
command line's refusals."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.design import load_design
from pnmold.diagnose.data import build_dataset
from pnmold.errors import DesignError
from pnmold.physics.characterisation import Characterisation
from pnmold.physics.uncertainty import DesignFloor, check_uncertain, moved_design, uncertainty_keys
from pnmold.recording import Recording
from pnmold.recording.measurement import measurement_of

P_FE = np.linspace(0.0, 40.0, 81)  # past every row / ratio the tests read (20 kPa x 1.5)


def law(p: np.ndarray, stiffness: float = 1.0, curl: float = 0.0) -> dict[str, np.ndarray]:
    """A made-up free run: bend and cavity volume growing with p / stiffness (``curl``: a change of shape)."""
    q = p / stiffness
    bend = 2.0 * q + 0.05 * q ** 2 + curl * q ** 3
    return {"pressure_kpa": p, "bend_angle_deg": bend, "tip_x_mm": 100.0 * np.cos(np.radians(bend)),
            "tip_z_mm": -100.0 * np.sin(np.radians(bend)), "cavity_volume_ml": 5.0 + 0.1 * q + 1e-3 * q ** 3,
            "max_principal_stretch": 1.0 + 0.01 * q}


def characterisation(moved: dict[str, dict[str, np.ndarray]], design, uncertain) -> Characterisation:
    runs = {key: {"format": 2, "value": uncertain[field], **{k: list(v) for k, v in moved[field].items()},
                  "free_length_mm": design.free_length_mm}
            for field, key in zip(sorted(uncertain), uncertainty_keys(uncertain), strict=True)}
    return Characterisation(**law(P_FE), variants=runs)


def bending(p: np.ndarray) -> Recording:
    return Recording("bend.csv", "bending", {"pressure_kpa": p, "bend_angle_deg": 2.0 * p}, {})


@pytest.fixture(scope="module")
def fpn():
    return load_design("fpn")


def test_a_dimension_that_only_scales_the_stiffness_leaves_no_floor(fpn):
    """The modulus is calibrated anyway: a wall that makes the actuator 20 % stiffer and nothing else
    changes nothing the recordings could be asked to show."""
    uncertain = {"chambers.outer_wall_mm": 0.5}
    floor = DesignFloor.of(fpn, characterisation({"chambers.outer_wall_mm": law(P_FE * 1.2, 1.2)}, fpn,
                                                 uncertain), uncertain)
    rows = floor.rows(bending(np.linspace(0.0, 30.0, 16)), "bend_angle_deg", 1.5)
    assert np.max(rows) < 0.02 * 2.0 * 30.0 / 1.5 * 0.05  # within the alignment grid's 0.25 % steps


def test_a_change_of_shape_is_the_floor_after_the_best_stiffness_and_dimensions_add_in_quadrature(fpn):
    uncertain = {"chambers.outer_wall_mm": 0.5, "chambers.inside_wall_mm": 0.2}
    moved = {"chambers.outer_wall_mm": law(P_FE, 1.0, 2e-3), "chambers.inside_wall_mm": law(P_FE, 1.0, -1e-3)}
    floor = DesignFloor.of(fpn, characterisation(moved, fpn, uncertain), uncertain)
    rec = bending(np.linspace(0.0, 20.0, 11))
    q = rec.columns["pressure_kpa"]
    expected = []
    for field in sorted(uncertain):  # the same alignment done here by brute force (every row reached)
        best = min((np.interp(q / r, P_FE, moved[field]["bend_angle_deg"])
                    - np.interp(q, P_FE, law(P_FE)["bend_angle_deg"]) for r in np.geomspace(1 / 1.5, 1.5, 161)),
                   key=lambda d: float(np.mean(d ** 2)))
        expected.append(best)
    rows = floor.rows(rec, "bend_angle_deg", 1.0)
    assert rows == pytest.approx(np.hypot(*expected), abs=1e-9)
    assert rows.max() > 0.5  # a cubic curl of 2e-3 at 20 kPa: 16 deg, most of it not a stiffness


def test_the_floor_reads_what_the_recording_reads(fpn):
    """A lab's bend over its own length and a P-V rig's volume read through the same measurement as
    the model's; a force recording gets none from the free runs alone (they have no blocked tip)."""
    uncertain = {"chambers.outer_wall_mm": 0.5}
    floor = DesignFloor.of(fpn, characterisation({"chambers.outer_wall_mm": law(P_FE, 1.0, 2e-3)}, fpn,
                                                 uncertain), uncertain)
    p = np.linspace(0.0, 20.0, 11)
    plain = floor.rows(bending(p), "bend_angle_deg", 1.0)
    meta = {"bending_length_mm": f"{fpn.free_length_mm / 2:g}"}
    half = Recording("bend.csv", "bending", {"pressure_kpa": p, "bend_angle_deg": p}, meta,
                     measurement=measurement_of(meta, "bend.csv"))
    assert floor.rows(half, "bend_angle_deg", 1.0) == pytest.approx(plain / 2, rel=1e-3, abs=1e-9)
    pv = Recording("pv.csv", "pv", {"pressure_kpa": p, "volume_ml": 0.1 * p}, {})
    assert floor.rows(pv, "volume_ml", 1.0).max() > 0
    force = Recording("f.csv", "force", {"pressure_kpa": p, "force_n": 0.01 * p}, {})
    assert not floor.rows(force, "force_n", 1.0).any()


def test_a_blocked_force_gets_the_share_each_dimension_changes_the_fes_blocked_tip(fpn):
    """With the moved designs' blocked tips (``uncertainty_runs(blocked=True)``) a force recording's floor is
    the shares they change the FE's blocked force, in quadrature, times each row's force; no alignment
    (a blocked force at low pressure hardly depends on the modulus): the same at any modulus scale."""
    uncertain = {"chambers.outer_wall_mm": 1.0, "paper.depth_mm": 1.0}
    c = characterisation({f: law(P_FE, 1.0, 1e-3) for f in uncertain}, fpn, uncertain)
    keys = dict(zip(sorted(uncertain), uncertainty_keys(uncertain), strict=True))
    variants = {**c.variants, keys["chambers.outer_wall_mm"]: {**c.variants[keys["chambers.outer_wall_mm"]],
                                                                "blocked_force_n": 0.0086},
                keys["paper.depth_mm"]: {**c.variants[keys["paper.depth_mm"]], "blocked_force_n": 0.0105}}
    c = dataclasses.replace(c, variants=variants, blocked={"pressure_kpa": 0.9, "force_n": 0.01})
    floor = DesignFloor.of(fpn, c, uncertain)
    assert floor.blocked == pytest.approx({"chambers.outer_wall_mm": -0.14, "paper.depth_mm": 0.05})
    p = np.linspace(0.0, 30.0, 16)
    force = Recording("f.csv", "force", {"pressure_kpa": p, "force_n": 0.02 * p}, {})
    expected = np.hypot(0.14, 0.05) * 0.02 * p
    assert floor.rows(force, "force_n", 1.0) == pytest.approx(expected)
    assert floor.rows(force, "force_n", 1.6) == pytest.approx(expected)
    assert floor.rows(bending(p), "bend_angle_deg", 1.0).max() > 0  # the free runs still read


def test_the_floor_adds_to_the_noise_in_quadrature_and_is_reported():
    p = np.linspace(0.0, 30.0, 16)
    rec = bending(p)
    base = [{"bend_angle_deg": 2.0 * p}]
    (plain,) = build_dataset([rec], base).series
    design = 0.1 * p
    (floored,) = build_dataset([rec], base, design_form=[{"bend_angle_deg": design}]).series
    assert floored.sigma == pytest.approx(np.hypot(plain.sigma, design))
    assert floored.design == pytest.approx(np.sqrt(np.mean(design ** 2)))


@pytest.mark.parametrize("field, value, words", [
    ("chambers.count", 1.0, "a design field in mm"),
    ("chamber.outer_wall_mm", 1.0, "no such section"),
    ("chambers.outer_wall_mm", 0.0, "must be a number > 0"),
    ("chambers.outer_wall_mm", float("nan"), "must be a number > 0"),
    ("chambers.height_mm", 500.0, "moved up by its uncertainty"),
])
def test_an_uncertain_dimension_the_design_cannot_take_is_refused_naming_it(fpn, field, value, words):
    with pytest.raises(DesignError) as err:
        check_uncertain(fpn, {field: value})
    assert err.value.field == field and words in str(err.value)


def test_moved_design_moves_one_dimension(fpn):
    moved = moved_design(fpn, "chambers.outer_wall_mm", 0.5)
    assert moved.chambers.outer_wall_mm == pytest.approx(fpn.chambers.outer_wall_mm + 0.5)
    assert moved.chambers.inside_wall_mm == fpn.chambers.inside_wall_mm


@pytest.mark.parametrize("arg, words", [("chambers.outer_wall_mm", "FIELD=MM"),
                                        ("chambers.outer_wall_mm=x", "FIELD=MM"),
                                        ("chambers.count=1", "chambers.count")])
def test_the_command_line_refuses_a_bad_uncertain_dimension_before_any_fe(arg, words, tmp_path, capsys):
    rec = tmp_path / "pv.csv"
    rec.write_text("# kind: pv\nvolume_ml,pressure_kpa\n0,0\n0.5,10\n1.0,20\n")
    out = tmp_path / "d.json"
    assert main(["diagnose", "fpn", str(rec), "--json", str(out), "--uncertain", arg]) == 2
    assert words in capsys.readouterr().err and not out.exists()


def test_with_a_force_recording_each_moved_design_gets_its_blocked_tip_once_at_the_probes_pressure(
        tmp_path, monkeypatch):
    """``uncertainty_runs(blocked=True)`` solves the design's blocked tip and each moved design's at the same
    pressure (the moved dimension in the solved design), keeps them in the cache, and runs nothing again;
    the floor then reads the shares. (The FE is stood in for: the moved free runs and the blocked tips.)"""
    import importlib
    import json

    from tests.test_rom_maximum import _bundled_fpn

    ch = importlib.import_module("pnmold.physics.characterise")
    design, full = _bundled_fpn()
    monkeypatch.setenv("PNMOLD_CACHE", str(tmp_path))
    path = ch.cache_path(design, ch.DEFAULT_SIZE, ch.DEFAULT_MAX_PRESSURE_KPA)
    from pnmold.fsutil import write_json

    write_json(path, dataclasses.replace(full, source="fe", blocked=None).to_json())
    uncertain = {"chambers.outer_wall_mm": 0.5, "paper.depth_mm": 0.25}
    tips = []

    def fake_tip(solved, pressure_kpa, size):
        tips.append((solved.chambers.outer_wall_mm, solved.paper.depth_mm, pressure_kpa))
        force = 0.01 * (1.0 - 0.2 * (solved.chambers.outer_wall_mm - design.chambers.outer_wall_mm)
                        + 0.4 * (solved.paper.depth_mm - design.paper.depth_mm))
        return {"pressure_kpa": pressure_kpa, "force_n": force, "seconds": 0.0}

    def fake_runs(solved, size, missing, say, pressures_kpa=None, max_pressure_kpa=None):
        return {k: {"format": ch.VARIANT_FORMAT, "value": float(k.partition("=")[2]),
                    **{c: list(v) for c, v in law(P_FE).items()}, "free_length_mm": design.free_length_mm}
                for k in missing}

    monkeypatch.setattr(ch, "_blocked_tip", fake_tip)
    monkeypatch.setattr(ch, "_run_variants", fake_runs)
    monkeypatch.setattr(ch, "variant_keys", lambda: [])
    c = ch.uncertainty_runs(design, uncertain, blocked=True)
    p = ch.BLOCKED_PROBE_SHARE * full.max_pressure_kpa
    w, d = design.chambers.outer_wall_mm, design.paper.depth_mm
    assert sorted(tips) == sorted([(w, d, pytest.approx(p)), (w + 0.5, d, pytest.approx(p)),
                                   (w, d + 0.25, pytest.approx(p))])
    stored = json.loads(path.read_text())["variants"]
    assert {k: v["blocked_force_n"] for k, v in stored.items() if k.startswith("design:")} == pytest.approx(
        {"design:chambers.outer_wall_mm=0.5": 0.009, "design:paper.depth_mm=0.25": 0.011})
    assert DesignFloor.of(design, c, uncertain).blocked == pytest.approx(
        {"chambers.outer_wall_mm": -0.1, "paper.depth_mm": 0.1})
    ch.uncertainty_runs(design, uncertain, blocked=True)
    assert len(tips) == 3  # cached: nothing runs again
