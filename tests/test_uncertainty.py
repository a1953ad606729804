"""The design's stated dimensional uncertainty as a floor under a diagnosis's noise
(``pnmold/physics/uncertainty.py``): on made-up FE curves with known answers (no FE here), and the
command line's refusals."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.design import load_design
from pnmold.diagnose.data import build_dataset
from pnmold.errors import DesignError
from pnmold.measurement import measurement_of
from pnmold.physics.characterisation import Characterisation
from pnmold.physics.uncertainty import DesignFloor, check_uncertain, moved_design, uncertainty_keys
from pnmold.recording import Recording

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
    the model's; force and step recordings get none (the free run has no force)."""
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
