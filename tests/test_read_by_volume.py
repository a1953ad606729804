"""A rig that sets the volume (a piston, a syringe pump) over one loading ramp is read by its volume:
the model is asked for the pressure at each recorded volume (pnmold.physics.reading.at_volumes).
Checked: which recordings are read so, the reading against the model's own pressure-driven curve, a
volume past the model's pressure maximum, and a diagnosis of a piston rig in air whose pressure
carries the rig's scatter (the volume is exact), where the air column is named at its size."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.physics import Protocol, ReducedModel
from pnmold.physics.protocol import read_by_volume
from pnmold.physics.reading import at_volumes
from pnmold.recording import Recording, read_recording, write_recording
from pnmold.recording.measurement import Measurement

PISTON = Measurement(rig="volume", medium="air")


def _pv(columns: dict, measurement: Measurement = PISTON, kind: str = "pv") -> Recording:
    return Recording("pv.csv", kind, {k: np.asarray(v) for k, v in columns.items()}, {}, measurement=measurement)


def test_only_a_volume_driven_single_ramp_is_read_by_its_volume():
    ramp = {"pressure_kpa": [0.0, 5.0, 9.0], "volume_ml": [0.0, 1.0, 2.0]}
    assert read_by_volume(_pv(ramp))
    assert read_by_volume(_pv(ramp, Measurement()))  # the supplement's syringe pump too
    assert not read_by_volume(_pv(ramp, Measurement(rig="pressure", medium="air")))  # a regulator sets p
    assert not read_by_volume(_pv({**ramp, "volume_ml": [0.0, 2.0, 1.0]}))  # the volume falls back
    assert not read_by_volume(_pv({**ramp, "cycle": [1, 1, 2]}))  # history: read in time order
    assert not read_by_volume(_pv({**ramp, "phase": np.array(["inflate", "inflate", "deflate"], dtype=object)}))
    assert not read_by_volume(_pv(ramp, kind="bending"))
    proto = Protocol.from_recording(_pv(ramp))
    assert proto.by_volume and proto.volume_ml.tolist() == [0.0, 1.0, 2.0]


def test_a_curve_is_read_at_volumes_up_to_its_maximum_and_extrapolated_only_where_it_did_not_end():
    p = np.array([0.0, 2.0, 4.0, 6.0, 8.0])
    curve = {"pressure_kpa": p, "volume_ml": np.array([0.0, 1.0, 3.0, 6.0, 6.0]),
             "bend_angle_deg": 10.0 * p, "beyond_fe": np.zeros(5, bool), "pressure_excess": np.zeros(5)}
    got = at_volumes(curve, np.array([0.5, 4.5, 9.0]))
    assert got["pressure_kpa"][:2] == pytest.approx([1.0, 5.0]) and got["bend_angle_deg"][1] == pytest.approx(50.0)
    # no maximum: the last slope (2 kPa per 3 mL) carries on, said as beyond what was characterised
    assert got["pressure_kpa"][2] == pytest.approx(8.0) and got["beyond_fe"].tolist() == [False, False, True]
    assert got["volume_excess"].tolist() == [0.0, 0.0, 0.0] and got["volume_ml"].tolist() == [0.5, 4.5, 9.0]
    ended = at_volumes({**curve, "pressure_excess": np.array([0, 0, 0, 0, 0.1])}, np.array([4.5, 12.0]))
    # the model's pressure maximum at 6 kPa and 6 mL: 12 mL is half out of its reach, read at the maximum
    assert ended["pressure_kpa"].tolist() == pytest.approx([5.0, 6.0])
    assert ended["volume_excess"].tolist() == pytest.approx([0.0, 0.5]) and not ended["pressure_excess"].any()


def test_the_model_read_by_volume_returns_the_pressures_of_its_own_pressure_driven_curve():
    """A pressure-driven run's volumes, read back by volume, give its pressures and its bend."""
    from pnmold.design import load_design

    rom = ReducedModel.for_design(load_design("fpn"))
    p = np.linspace(0.0, 30.0, 13)
    effects = {"gravity": 0.0, "dead_volume": 40.0}
    driven = rom.run(Protocol("pv", p, "horizontal", measurement=PISTON), effects)
    read = rom.run(Protocol("pv", p, "horizontal", measurement=PISTON, volume_ml=driven["volume_ml"]), effects)
    assert read["volume_ml"] == pytest.approx(driven["volume_ml"])
    assert read["pressure_kpa"] == pytest.approx(p, abs=0.05)  # linear between grid points 0.75 kPa apart
    assert read["bend_angle_deg"] == pytest.approx(driven["bend_angle_deg"], abs=0.1)


@pytest.mark.slow
def test_a_piston_ramp_with_a_scattered_pressure_names_its_air_column(tmp_path):
    """One loading ramp of a piston in air (120 mL of air the recording does not state), its pressure read
    with the rig's scatter (0.3 kPa) at exact piston volumes: read by volume, the air column is named at
    its size, the modulus recovered, and the misfit located by the volume the rig set."""
    from pnmold.design import load_design

    rom = ReducedModel.for_design(load_design("fpn"))
    p = np.linspace(0.0, 36.0, 19)
    truth = rom.run(Protocol("pv", p, "horizontal", measurement=PISTON),
                    {"dead_volume": 120.0}, None, {"modulus_scale": 0.9})
    measured = p + np.random.default_rng(3).normal(0.0, 0.3, p.size) * (p > 0)
    path = tmp_path / "piston.csv"
    write_recording(path, "pv", {"volume_ml": truth["volume_ml"], "pressure_kpa": measured},
                    {"orientation": "horizontal", "rig": "volume", "medium": "air"})
    assert read_by_volume(read_recording(path))
    out = tmp_path / "d.json"
    assert main(["diagnose", "fpn", str(path), "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert [m["effect"] for m in d["missing_physics"]] == ["dead_volume"] and not d["unexplained"]
    assert d["missing_physics"][0]["parameters"]["dead_volume"] == pytest.approx(120.0, rel=0.05)
    assert d["calibration"]["final"]["modulus_scale"] == pytest.approx(0.9, rel=0.05)
    assert d["fit"]["observable"] == "pressure_kpa" and "volume_ml" in d["mismatch"][0]["window"]


def test_a_simulated_pv_recording_holds_the_volume_its_rig_reads(tmp_path):
    """``pnmold simulate --model rom --kind pv --effects dead_volume=V --recording``: the recording's volume
    is the rig's reading, the cavity's change plus the trapped air's compression (water rig: V p / (p_atm + p)),
    so that a diagnosis of it can find the air (it was the cavity's change alone)."""
    from pnmold.physics.reading import P_ATM_KPA

    paths = {v: tmp_path / f"pv{v}.csv" for v in (0, 4)}
    for v, path in paths.items():
        assert main(["simulate", "fpn", "--model", "rom", "--kind", "pv", "--pressures", "0:40:10", "--effects",
                     f"dead_volume={v},gravity=0", "--recording", str(path), "--json", str(path.with_suffix(".json")),
                     "--quiet"]) == 0
    plain, trapped = (read_recording(paths[v]) for v in (0, 4))
    p = plain["pressure_kpa"]
    np.testing.assert_allclose(trapped["volume_ml"] - plain["volume_ml"], 4.0 * p / (P_ATM_KPA + p), atol=1e-4)
    steps = json.loads(paths[4].with_suffix(".json").read_text())["steps"]
    assert [s["volume_ml"] for s in steps] == pytest.approx(trapped["volume_ml"].tolist(), rel=1e-5)
