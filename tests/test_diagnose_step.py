"""``pnmold diagnose`` on ``step`` recordings: the step model at the diagnosis's tolerances
replaying ``simulate_step``'s recordings (the same compiled model, tighter), the protocol and
the bench read from a recording, the routing of effects in mixed diagnoses, and (slow) a
small fixed subset of ``benchmarks/diagnose_blind_step.py`` on the fPN with the JSON
contract of a step diagnosis."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.design import load_design
from pnmold.errors import RecordingError
from pnmold.pneumatics import ActuatorLine, BendingDynamics, Orifice, Rig, StepModel, StepProtocol, simulate_step
from pnmold.recording import Recording
from pnmold.simulate.dynamic import recording_metadata
from tests.test_pneumatics import linear_law

OBSERVED = ("pressure_kpa", "flow_slpm", "bend_angle_deg")
EXTRAS = ("pressure_far_kpa", "volume_ml")  # pnmold's own step columns, compared when recorded


def _recording(t, supply, meta=None, **cols) -> Recording:
    columns = {"time_s": np.asarray(t, float), "supply_kpa": np.asarray(supply, float),
               "pressure_kpa": np.zeros(len(t)), **cols}
    return Recording("rec.csv", "step", columns, dict(meta or {}))


# -- the diagnosis's step model against simulate_step ----------------------------------------
@pytest.mark.parametrize(("effects", "scale"), [({}, 1.0), ({"dead_volume": 6.0}, 1.15),
                                                ({"flow_restriction": 2.0}, 0.9)],
                         ids=["nominal", "dead_volume", "flow_restriction"])
def test_step_model_reproduces_simulate_step(effects, scale):
    design = load_design("fpn")
    law = linear_law()
    rig = Rig(120.0, vent_at_s=0.06, dead_volume_ml=effects.get("dead_volume", 0.0),
              flow_restriction=effects.get("flow_restriction", 0.0))
    ref = simulate_step(law.scaled(scale), ActuatorLine.from_design(design), BendingDynamics.from_design(design),
                        rig, duration_s=0.12)
    cols = {k: ref.series[k][::4] for k in ("time_s", "supply_kpa", *OBSERVED, *EXTRAS)}
    protocol = StepProtocol.from_recording(Recording("sim.csv", "step", cols, {}))
    assert protocol.supply_kpa == 120.0 and protocol.switch_s.tolist() == pytest.approx([0.0, 0.06, 0.12])
    out = StepModel(design, law).run(protocol, effects, {"modulus_scale": scale})
    for k in (*OBSERVED, *EXTRAS):
        span = float(np.ptp(cols[k]))
        assert span > 0
        assert np.max(np.abs(out[k] - cols[k])) < 1e-3 * span, k


def test_the_bench_of_a_simulated_recording_is_read_back_whole():
    """Valves, valve volume, tubing, atmosphere and temperature travel in the recording's
    metadata; the replay matches only if every one reaches the model (defaults would not)."""
    design = load_design("fpn")
    law = linear_law()
    valve = Orifice.from_diameter_mm(0.7, 0.3)
    rig = Rig(150.0, valve, valve, tubing_length_mm=500.0, tubing_id_mm=1.2, valve_volume_ml=0.4,
              atmosphere_kpa=85.0, temperature_k=308.0, vent_at_s=0.06)
    ref = simulate_step(law, ActuatorLine.from_design(design), BendingDynamics.from_design(design), rig,
                        duration_s=0.12)
    cols = {k: ref.series[k][::4] for k in ("time_s", "supply_kpa", *OBSERVED, *EXTRAS)}
    meta = {k: str(v) for k, v in recording_metadata(design, rig, {}).items()}
    model = StepModel(design, law)
    replay = model.run(StepProtocol.from_recording(Recording("sim.csv", "step", cols, meta)))
    default = model.run(StepProtocol.from_recording(Recording("sim.csv", "step", cols, {})))
    for k in (*OBSERVED, *EXTRAS):
        span = float(np.ptp(cols[k]))
        assert np.max(np.abs(replay[k] - cols[k])) < 1e-3 * span, k
    assert np.max(np.abs(default["pressure_kpa"] - cols["pressure_kpa"])) > 0.05 * np.ptp(cols["pressure_kpa"])


def test_effects_and_calibration_move_the_step_response_their_own_way():
    design = load_design("fpn")
    model = StepModel(design, linear_law())
    t = np.arange(0.0, 0.2, 0.002)
    protocol = StepProtocol.from_recording(_recording(t, np.where(t < 0.1, 150.0, 0.0)))
    nominal = model.run(protocol)
    dead = model.run(protocol, {"dead_volume": 5.0})
    slow = model.run(protocol, {"flow_restriction": 3.0})
    stiff = model.run(protocol, {}, {"modulus_scale": 1.3})
    i = np.searchsorted(t, 0.05)
    # dead volume: the same choked supply flow at first, a slower rise of the inlet pressure
    assert dead["flow_slpm"][0] == pytest.approx(nominal["flow_slpm"][0], rel=1e-9)
    assert dead["pressure_kpa"][i] < nominal["pressure_kpa"][i] - 1.0
    # restriction: every flow divided by 1 + k at the start
    assert slow["flow_slpm"][0] == pytest.approx(nominal["flow_slpm"][0] / 4.0, rel=1e-6)
    # stiffer rubber: the pressure rises faster (less volume to fill) ...
    assert stiff["pressure_kpa"][i] > nominal["pressure_kpa"][i] + 1.0
    # ... and, once settled, the same pressure holds 1 / 1.3 of the bend (the law at p / s)
    t = np.arange(0.0, 3.0, 0.01)
    settled = StepProtocol.from_recording(_recording(t, np.full(t.size, 30.0)))
    nominal, stiff = model.run(settled), model.run(settled, {}, {"modulus_scale": 1.3})
    assert nominal["pressure_kpa"][-1] == pytest.approx(30.0, abs=0.05)
    assert stiff["pressure_kpa"][-1] == pytest.approx(30.0, abs=0.05)
    assert stiff["bend_angle_deg"][-1] == pytest.approx(nominal["bend_angle_deg"][-1] / 1.3, rel=0.01)
    with pytest.raises(Exception, match="modulus_scale"):
        model.run(protocol, {}, {"modulus_scale": -1.0})


# -- the protocol of a recording ------------------------------------------------------------
def test_protocol_reads_level_switches_and_bench_from_the_recording():
    i = np.arange(110)
    t = (i - 10) * 1e-3  # 10 rows before the valve opens at t = 0
    supply = np.where((i >= 10) & (i < 40), 200.0, 0.0) + np.where(i >= 70, 200.0, 0.0)
    supply[10:20] += 0.8  # a noisy regulator: the level is the median
    rec = _recording(t, supply, {"tubing_length_mm": "500", "tubing_id_mm": "1.2", "valve_orifice_mm": "0.8"})
    p = StepProtocol.from_recording(rec)
    assert p.supply_kpa == pytest.approx(200.0)
    assert p.switch_s.tolist() == [t[10], t[40], t[70], t[-1]] and t[10] == 0.0
    assert p.phases.tolist() == [0, 1, 0]
    assert (p.tubing_length_mm, p.tubing_id_mm) == (500.0, 1.2)
    assert p.supply_valve.conductance_l_per_s_bar == pytest.approx(
        0.64 * StepProtocol.from_recording(_recording(t, supply)).supply_valve.conductance_l_per_s_bar)
    # before the valve opens the actuator is at rest
    out = StepModel(load_design("fpn"), linear_law()).run(p)
    before = t < 0.0
    assert np.all(out["pressure_kpa"][before] == 0.0) and np.all(out["flow_slpm"][before] == 0.0)
    assert np.all(out["pressure_kpa"][~before][1:] > 0.0)


@pytest.mark.parametrize(("supply", "meta", "message"), [
    (np.zeros(5), {}, "never opens"),
    (np.array([0, 0, 0, 0, 100.0]), {}, "only at the last row"),
    (np.full(5, 100.0), {"tubing_length_mm": "long"}, "tubing_length_mm"),
    (np.full(5, 100.0), {"gas_law": "adiabatic"}, "isothermal"),
])
def test_protocol_refuses_what_it_cannot_reproduce(supply, meta, message):
    with pytest.raises(RecordingError, match=message):
        StepProtocol.from_recording(_recording(np.arange(5) * 0.01, supply, meta))


# -- candidates and the mixed forward -------------------------------------------------------
def test_candidates_without_step_are_the_reduced_models_and_with_step_add_the_pneumatic_ones():
    from pnmold.diagnose.model import candidate_effects, diagnosis_effects

    bending = Recording("b.csv", "bending", {"pressure_kpa": np.zeros(3), "tip_x_mm": np.zeros(3),
                                             "tip_z_mm": np.zeros(3)})
    step = _recording([0.0, 0.1], [100.0, 100.0])
    assert diagnosis_effects([bending]) == candidate_effects([bending])
    assert [e.name for e in diagnosis_effects([step])] == ["dead_volume", "flow_restriction"]
    mixed = [e.name for e in diagnosis_effects([bending, step])]
    assert mixed == [e.name for e in candidate_effects([bending])] + ["dead_volume", "flow_restriction"]


def test_mixed_forward_routes_each_effect_to_the_model_that_carries_it(monkeypatch, rom):
    import pnmold.pneumatics.law as law_module
    from pnmold.diagnose.model import diagnosis_forward, rom_forward
    from pnmold.physics.protocol import Protocol
    from pnmold.physics.rom import ReducedModel

    monkeypatch.setattr(law_module, "chamber_law_for", lambda design, progress=None: linear_law())
    monkeypatch.setattr(ReducedModel, "for_design", classmethod(lambda cls, design: rom))
    proto = Protocol.ramp("bending", 30.0, 5.0, 1, 2.0, "chambers_up")
    bending = Recording("b.csv", "bending", {"pressure_kpa": proto.pressure_kpa, "tip_x_mm": proto.pressure_kpa * 0,
                                             "tip_z_mm": proto.pressure_kpa * 0, "cycle": proto.cycle,
                                             "phase": proto.phase}, {"orientation": "chambers_up"})
    t = np.arange(0.0, 0.1, 0.002)
    step = _recording(t, np.where(t < 0.05, 150.0, 0.0))
    design = load_design("fpn")
    forward = diagnosis_forward(design, [bending, step])
    alone = rom_forward(design, [bending])
    base = forward({}, {"modulus_scale": 1.1})
    np.testing.assert_array_equal(base[0]["tip_z_mm"], alone({}, {"modulus_scale": 1.1})[0]["tip_z_mm"])
    dead = forward({"dead_volume": 4.0}, {"modulus_scale": 1.1})
    np.testing.assert_array_equal(dead[0]["tip_z_mm"], base[0]["tip_z_mm"])  # the ROM does not carry it
    assert np.max(np.abs(dead[1]["pressure_kpa"] - base[1]["pressure_kpa"])) > 1.0
    grav = forward({"gravity": 0.3}, {"modulus_scale": 1.1})  # a weight other than the declared 1 g
    np.testing.assert_array_equal(grav[1]["pressure_kpa"], base[1]["pressure_kpa"])  # the step model does not
    assert np.max(np.abs(grav[0]["tip_z_mm"] - base[0]["tip_z_mm"])) > 0.1


# -- a small fixed subset of the blind step benchmark (data from simulate_step) -------------
SUBSET = [  # (id, effect, value, modulus scale, supply kPa, pulse share, snr or null noise)
    ("null", None, 0.0, 1.08, 300.0, 0.8, 0.004),
    ("dead_volume", "dead_volume", 6.0, 1.06, 250.0, 0.75, 6.0),
    ("flow_restriction", "flow_restriction", 2.5, 0.94, 150.0, 0.7, 6.0),
]


def _case(cid, effect, value, scale, supply, share, noise):
    from benchmarks.diagnose_blind_step import Case, pulse

    t_vent, duration, period = pulse("fpn", supply, share)
    return Case(cid, "fpn", effect, value, scale, supply, t_vent, duration, period, noise if effect else 6.0,
                noise if not effect else 0.0, 17)


@pytest.mark.slow
@pytest.mark.parametrize("case", SUBSET, ids=[c[0] for c in SUBSET])
def test_blind_step_subset_names_the_concealed_effect(case, tmp_path):
    from benchmarks.diagnose_blind_step import generate

    c = _case(*case)
    generate(c, tmp_path)
    text = (tmp_path / "step.csv").read_text()
    assert "# kind: step" in text and c.id not in text and "dead" not in text and "restriction" not in text
    out = tmp_path / "d.json"
    argv = ["diagnose", "fpn", str(tmp_path / "step.csv"), "--json", str(out), "--quiet"]
    if c.effect == "dead_volume":
        argv += ["--report", str(tmp_path / "report")]
    assert main(argv) == 0
    doc = json.loads(out.read_text())
    named = [m["effect"] for m in doc["missing_physics"]]
    assert doc["seconds"] < 30
    if c.effect is None:
        assert named == [] and doc["unexplained"] is False
        assert doc["baseline"]["calibrated"]["modulus_scale"] == pytest.approx(c.modulus_scale, rel=0.02)
        return
    assert named[:1] == [c.effect]
    assert doc["missing_physics"][0]["parameters"][c.effect] == pytest.approx(c.value, rel=0.2)
    final = next(x for x in doc["candidates"] if x["effect"] == c.effect)
    # the modulus to its statistical uncertainty: in a step the flow restriction and the
    # modulus both slow the rise, and trade for each other. Measured on the flow_restriction
    # case (v2 characterisation): fitted 0.909 for 0.94, chi-square 1095.3 there and 1098.3 at
    # the true values -- the truth inside the fit's 68 % region; 5 % holds it, a biased fit
    # (the truth outside) would not
    assert final["parameters"]["modulus_scale"] == pytest.approx(c.modulus_scale, rel=0.05)
    assert doc["fit"]["heldout_rmse_before"] >= 3 * doc["fit"]["heldout_rmse_after"]
    assert doc["mismatch"] and doc["mismatch"][0]["significance"] > 4
    if c.effect == "dead_volume":
        _check_contract(doc, tmp_path / "report")


def _check_contract(doc, report):
    """The document (docs/json-schemas.md) of a step diagnosis, and its report folder."""
    assert doc["schema"] == "pnmold.diagnosis/1"
    for key in ("design", "recordings", "baseline", "mismatch", "missing_physics", "unexplained", "fit"):
        assert key in doc, key
    assert doc["recordings"][0]["kind"] == "step"
    assert set(doc["baseline"]) >= {"calibrated", "rmse", "heldout_rmse"}
    assert set(doc["baseline"]["calibrated"]) == {"modulus_scale"}
    assert set(doc["fit"]) >= {"rmse_before", "rmse_after", "heldout_rmse_before", "heldout_rmse_after"}
    assert set(doc["noise"]) == {"pressure_kpa[0]", "bend_angle_deg[0]", "flow_slpm[0]"}
    assert {c["effect"] for c in doc["candidates"]} == {"dead_volume", "flow_restriction"}
    m = doc["missing_physics"][0]
    assert m["effect"] == "dead_volume" and set(m["parameters"]) == {"dead_volume"}
    assert set(m["uncertainty"]) == {"dead_volume"} and set(m["evidence"]) >= {"heldout_chi2_gain"}
    assert "dead_volume" in m["explanation"] and "held-out error fell" in m["explanation"]
    assert doc["mismatch"][0]["observable"] in OBSERVED and "time_s" in doc["mismatch"][0]["window"]
    page = (report / "report.html").read_text()
    assert "data:image/png;base64," in page and "dead_volume" in page
    assert (report / "fits.png").stat().st_size > 20_000


@pytest.mark.slow
def test_mixed_step_and_bending_diagnosis_names_the_pneumatic_effect(tmp_path):
    """A step recording beside a bending ramp of the same actuator: one modulus for both, the
    reduced model's effects judged too, the dead volume named from the step recording."""
    from benchmarks.diagnose_blind_step import generate
    from pnmold.physics import Protocol, ReducedModel
    from pnmold.physics.characterise import characterise
    from pnmold.recording import write_recording

    fpn = load_design("fpn")
    p_max = 0.75 * characterise(fpn).full_bend_pressure_kpa
    ramp = Protocol.ramp("bending", p_max, p_max / 15, 3, 2.0, "chambers_up")
    cols = ReducedModel.for_design(fpn).run(ramp, {}, None, {"modulus_scale": 1.05})  # a batch 5 % stiffer
    rng = np.random.default_rng(3)
    write_recording(tmp_path / "bending.csv", "bending",
                    {"pressure_kpa": ramp.pressure_kpa, "cycle": ramp.cycle, "phase": ramp.phase,
                     "time_s": ramp.times_s(), **{k: cols[k] + rng.normal(0.0, 0.2, len(ramp))
                                                for k in ("tip_x_mm", "tip_z_mm")}},
                    {"orientation": "chambers_up", "rate_kpa_per_s": "2"})
    generate(_case("m", "dead_volume", 6.0, 1.05, 250.0, 0.75, 6.0), tmp_path)
    out = tmp_path / "d.json"
    assert main(["diagnose", "fpn", str(tmp_path / "step.csv"), str(tmp_path / "bending.csv"), "--json", str(out),
                 "--quiet"]) == 0
    doc = json.loads(out.read_text())
    assert [r["kind"] for r in doc["recordings"]] == ["step", "bending"]
    assert {"gravity", "layer_compliance", "dead_volume", "flow_restriction"} <= {c["effect"] for c in
                                                                               doc["candidates"]}
    assert [m["effect"] for m in doc["missing_physics"]] == ["dead_volume"]
    assert doc["missing_physics"][0]["parameters"]["dead_volume"] == pytest.approx(6.0, rel=0.2)
    final = next(x for x in doc["candidates"] if x["effect"] == "dead_volume")
    assert final["parameters"]["modulus_scale"] == pytest.approx(1.05, rel=0.03)
