"""How a recording reads the model (pnmold.physics.reading, pnmold.recording.measurement): closed forms, and
diagnoses of recordings measured in a lab's own way (camera frame, bend angle over another length,
a piston rig compressing air) that register the measurement instead of blaming physics."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.errors import RecordingError
from pnmold.physics import Protocol, ReducedModel
from pnmold.physics.reading import P_ATM_KPA, T_LAB_K, T_STD_K, read_bend, read_tip, read_volume
from pnmold.recording import read_recording, write_recording
from pnmold.recording.measurement import Measurement


def test_a_trapped_bubble_and_a_piston_compress_isothermally():
    p = np.array([0.0, 10.0, 101.325])
    dv = np.array([0.0, 1.0, 3.0])
    water = read_volume(dv, 5.0, p, Measurement(medium="water"), dead_volume_ml=2.0)
    assert water == pytest.approx(dv + 2.0 * p / (P_ATM_KPA + p))
    assert water[2] - dv[2] == pytest.approx(1.0)  # a 2 mL bubble halves at one atmosphere gauge
    piston = read_volume(dv, 5.0, p, Measurement(rig="volume", medium="air", air_column_ml=95.0))
    # Boyle: p_atm (V_c0 + V_a) = (p_atm + p)(V_c0 + V_a + dV - piston)
    assert P_ATM_KPA * 100.0 == pytest.approx((P_ATM_KPA + p) * (100.0 + dv - piston))
    metered = read_volume(dv, 5.0, p, Measurement(rig="pressure", medium="air"))
    # the gas added, as standard mL: (p V - p_atm V_0) / p_std x T_std / T
    gas = ((P_ATM_KPA + p) * (5.0 + dv) - P_ATM_KPA * 5.0) / P_ATM_KPA * T_STD_K / T_LAB_K
    assert metered == pytest.approx(gas) and metered[0] == 0.0


def test_a_camera_frame_turns_and_offsets_the_tip_and_rest_subtracts_the_rest():
    x, z = np.array([100.0, 80.0]), np.array([0.0, -30.0])
    cx, cz = read_tip(x, z, (100.0, -5.0), Measurement(tip_origin="camera"),
                      {"frame_dx_mm": 3.0, "frame_dz_mm": -2.0, "frame_rotation_deg": 90.0})
    assert cx == pytest.approx([3.0, 33.0]) and cz == pytest.approx([98.0, 78.0])
    rx, rz = read_tip(x, z, (100.0, -5.0), Measurement(tip_origin="rest"), {})
    assert rx == pytest.approx([0.0, -20.0]) and rz == pytest.approx([5.0, -25.0])
    assert read_bend(np.array([90.0]), Measurement(bending_length_mm=50.0), 100.0) == pytest.approx([45.0])


def test_measurement_metadata_is_checked_naming_the_key(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("# kind: pv\n# rig: pump\nvolume_ml,pressure_kpa\n0,0\n1,2\n")
    with pytest.raises(RecordingError, match="metadata rig must be one of volume, pressure"):
        read_recording(path)
    path.write_text("# kind: bending\n# bending_length_mm: -4\npressure_kpa,bend_angle_deg\n0,0\n1,2\n")
    with pytest.raises(RecordingError, match="bending_length_mm"):
        read_recording(path)


def _measured(tmp_path, name, kind, meta, columns, effects, calibration, cycles=2, top_kpa=40.0, noise=None):
    """A recording of ``kind`` with ``meta`` whose measured columns the reduced model (fPN) fills,
    read through the recording's own measurement, with Gaussian noise (seeded); held horizontal, as
    declared (its weight on: the body rolls)."""
    proto = Protocol.from_pressures(kind, np.linspace(0.0, top_kpa, 17), cycles, None, "horizontal")
    placeholder = {"pressure_kpa": proto.pressure_kpa, **{c: np.zeros(len(proto)) for c in columns},
                   "cycle": proto.cycle, "phase": proto.phase}
    path = tmp_path / f"{name}.csv"
    write_recording(path, kind, placeholder, {"orientation": "horizontal", **meta})
    rec = read_recording(path)
    out = ReducedModel.for_design(_fpn()).run(Protocol.from_recording(rec), effects, None, calibration)
    rng = np.random.default_rng(7)
    filled = {**placeholder, **{c: out[c] + rng.normal(0.0, (noise or {}).get(c, 0.05), len(proto))
                                for c in columns}}
    write_recording(path, kind, filled, {"orientation": "horizontal", **meta})
    return path


def _fpn():
    from pnmold.design import load_design

    return load_design("fpn")


def _diagnose(tmp_path, *paths) -> dict:
    out = tmp_path / "d.json"
    assert main(["diagnose", "fpn", *map(str, paths), "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


@pytest.mark.slow
def test_a_camera_frame_is_registered_not_blamed_on_physics(tmp_path):
    frame = {"frame_dx_mm": 12.0, "frame_dz_mm": -7.0, "frame_rotation_deg": 4.0}
    path = _measured(tmp_path, "camera", "bending", {"tip_origin": "camera"}, ("tip_x_mm", "tip_z_mm"),
                     {}, {"modulus_scale": 1.1, **frame}, noise={"tip_x_mm": 0.2, "tip_z_mm": 0.2})
    d = _diagnose(tmp_path, path)
    assert d["missing_physics"] == [] and not d["unexplained"]
    got = d["calibration"]["final"]
    assert got["modulus_scale"] == pytest.approx(1.1, rel=0.02)
    for key, value in frame.items():
        assert got[key] == pytest.approx(value, abs=0.3), key
    assert "camera frame offset" in d["summary"]


@pytest.mark.slow
def test_a_piston_rigs_air_column_is_named_dead_volume_with_its_size(tmp_path):
    """A volume-driven P-V test in air: the piston compresses the cavity's own air (modelled) and an
    air column the recording does not state: dead_volume, with its size."""
    path = _measured(tmp_path, "pv", "pv", {"rig": "volume", "medium": "air"}, ("volume_ml",),
                     {"dead_volume": 120.0}, {"modulus_scale": 0.9}, noise={"volume_ml": 0.05})
    d = _diagnose(tmp_path, path)
    assert [m["effect"] for m in d["missing_physics"]] == ["dead_volume"]
    assert d["missing_physics"][0]["parameters"]["dead_volume"] == pytest.approx(120.0, rel=0.05)
    assert d["calibration"]["final"]["modulus_scale"] == pytest.approx(0.9, rel=0.05)
    check = d["missing_physics"][0]["rig_check"]  # the recording's own rows bound the air: 120 mL fits
    assert check["consistent"] and check["air_bound_ml"] >= 120.0 and "is within it" in d["summary"]


def test_the_rows_of_a_piston_recording_bound_its_air_column():
    """Boyle's law on the recording alone: the stroke at each row went into the cavity (>= 0) and the
    air, so the air is at most stroke x (p_atm + p) / p; a dead volume above that is said to be too large.
    Other rigs have no such bound."""
    from pnmold.diagnose.explain import air_column_bound, dead_volume_check
    from pnmold.recording import Recording

    p = np.array([0.0, 1.0, 5.0, 10.0, 20.0])
    cavity = np.array([0.0, 0.0, 0.1, 0.3, 1.0])  # the cavity's own change, mL
    air, rest = 60.0, 1.0
    stroke = cavity + (air + rest) * p / (P_ATM_KPA + p)
    rec = Recording("pv.csv", "pv", {"pressure_kpa": p, "volume_ml": stroke}, {},
                    measurement=Measurement(rig="volume", medium="air"))
    bound = air_column_bound(rec, rest)
    # rows below 10 % of the top pressure are left out; at 5 kPa: 60 + 0.1 x 106.3 / 5
    assert bound["pressure_kpa"] == 5.0 and bound["bound_ml"] == pytest.approx(air + 0.1 * (P_ATM_KPA + 5) / 5)
    assert dead_volume_check(60.0, 1.0, bound)[0]
    fits, words = dead_volume_check(80.0, 1.0, bound)
    assert not fits and "too large" in words and f"{bound['bound_ml']:.3g} mL" in words
    assert air_column_bound(Recording("pv.csv", "pv", rec.columns, {}, measurement=Measurement()), rest) is None
    # the rig's stated accuracy reads every row at its most generous: more stroke, less pressure
    loose = air_column_bound(Recording("pv.csv", "pv", rec.columns, {}, measurement=Measurement(
        rig="volume", medium="air", pressure_accuracy_kpa=1.0, volume_accuracy_ml=0.1)), rest)
    assert loose["exact_ml"] == pytest.approx(bound["bound_ml"])
    widest = min((v + 0.1) * (P_ATM_KPA + q - 1.0) / (q - 1.0) for q, v in zip(p[2:], stroke[2:], strict=True))
    assert loose["bound_ml"] == pytest.approx(widest - rest)
    assert not dead_volume_check(70.0, 1.0, bound)[0]  # above the readings' bound (62.1 mL) ...
    fits, words = dead_volume_check(70.0, 1.0, loose)  # ... within the rig's accuracy (69.7 mL)
    assert fits and "within the rig's stated accuracy (+-1 kPa, +-0.1 mL" in words


@pytest.mark.slow
def test_a_bend_angle_over_the_labs_length_is_read_as_such(tmp_path):
    """A bending test that records only the bend angle, computed over a longer length than the
    actuator's free length: the model's angle is scaled, nothing is blamed."""
    path = _measured(tmp_path, "angle", "bending", {"bending_length_mm": 130.0}, ("bend_angle_deg",),
                     {}, {"modulus_scale": 1.2}, noise={"bend_angle_deg": 0.3})
    rec = read_recording(path)
    assert set(rec.columns) >= {"pressure_kpa", "bend_angle_deg"} and "tip_x_mm" not in rec.columns
    d = _diagnose(tmp_path, path)
    assert d["missing_physics"] == [] and not d["unexplained"]
    assert d["calibration"]["final"]["modulus_scale"] == pytest.approx(1.2, rel=0.02)
    assert d["fit"]["observable"] == "bend_angle_deg"


@pytest.mark.slow
def test_a_rubber_far_from_the_designs_is_reported_as_the_material(tmp_path):
    path = _measured(tmp_path, "hard", "bending", {}, ("tip_x_mm", "tip_z_mm"), {},
                     {"modulus_scale": 8.0}, top_kpa=300.0, noise={"tip_x_mm": 0.3, "tip_z_mm": 0.3})
    d = _diagnose(tmp_path, path)
    check = d["calibration"]["material_check"]
    assert not check["in_window"] and check["modulus_scale"] == pytest.approx(8.0, rel=0.02)
    assert "8 times stiffer" in d["summary"] and "check the material" in d["summary"]
    assert d["missing_physics"] == [] and not d["unexplained"]
