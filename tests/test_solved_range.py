"""Laws within what was solved (issue 43, deliverable 4): the step model, ``simulate --dynamic`` and the
characterisation never read a chamber law past the FE's last solved step; they end there with its reason."""

from __future__ import annotations

import importlib
import json

import numpy as np
import pytest

from pnmold.cli import main
from pnmold.design import load_design
from pnmold.physics.characterisation import Characterisation
from pnmold.pneumatics import ActuatorLine, BendingDynamics, Rig, StepModel, StepProtocol, simulate_step
from pnmold.pneumatics.law import chamber_law_for
from pnmold.pneumatics.protocol import valve_schedule
from tests.test_pneumatics import BEND, LINE3, SMALL, linear_law

SPN = load_design("spn")


def test_spn_dynamic_at_345_kpa_never_reports_past_the_fe(tmp_path):
    """The acceptance line: ``simulate spn --dynamic --supply-kpa 345``. The sPN's FE curve ends at its
    pressure maximum (138.6 kPa, 195.7 deg, 150.9 mL): no chamber pressure, volume or bend past it, no
    quasi-static full bend drawn past it; run long enough, the response ends when a chamber reaches it."""
    law = chamber_law_for(SPN)
    assert law.end.stop == "pressure_maximum" and law.full_bend_kpa() is None
    for duration in ("0.5", "3"):
        out = tmp_path / f"spn-{duration}.json"
        assert main(["simulate", "spn", "--dynamic", "--supply-kpa", "345", "--duration-s", duration,
                     "--json", str(out), "--quiet"]) == 0
        doc = json.loads(out.read_text())
        s = doc["series"]
        assert np.max(doc["chamber_pressure_kpa"]) <= law.top_kpa * (1 + 1e-9)
        assert np.max(s["pressure_far_kpa"]) <= law.top_kpa * (1 + 1e-9)
        assert np.max(s["cavity_volume_ml"]) <= law.end.volume_ml * (1 + 1e-6)
        assert np.max(s["bend_angle_deg"]) <= law.top_deg + 1e-6
        assert doc["full_bend_pressure_kpa"] is None and doc["time_to_full_bend_s"] is None
        assert doc["model_info"]["quasi_static_angle_at_supply_deg"] is None
        assert doc["model_info"]["volume_change_at_full_bend_ml"] is None
        # 0.5 s: no chamber reaches it yet
        assert duration == "3" or "not reached within the FE's solved range (ends at 138.6 kPa, 195.7 deg" \
            in doc["reason"]
    # 3 s: chamber 1 reaches the maximum (at about 1.8 s) and the response ends there
    assert doc["model_info"]["stopped_at_law_end_s"] == pytest.approx(s["time_s"][-1], abs=5e-4)
    assert 1.0 < s["time_s"][-1] < 3.0 and np.max(doc["chamber_pressure_kpa"]) > 0.999 * law.top_kpa
    assert "chamber 1 reached 138.6 kPa, the last pressure the FE solved" in doc["model_info"]["stopped_by"]


def test_the_spn_summary_says_full_bend_is_not_within_the_solved_range(capsys, tmp_path):
    assert main(["simulate", "spn", "--dynamic", "--supply-kpa", "345", "--plot", str(tmp_path / "p.png")]) == 0
    text = capsys.readouterr().out
    assert "quasi-static full bend: not reached within the FE's solved range (ends at 138.6 kPa, 195.7 deg: " \
           "pressure maximum" in text
    assert "245.0 kPa" not in text and "443" not in text


def test_the_step_model_stops_where_a_chamber_reaches_the_laws_last_pressure():
    """A law known to 60 kPa against the same law known to 400 kPa: the same trajectory up to the time
    the near chamber reaches 60 kPa, located on the integrator's interpolant; nothing after it."""
    rig = Rig(100.0, tubing_length_mm=100.0)
    schedule = valve_schedule(None, 0.1, 5e-4)
    short = StepModel.from_parts(linear_law(p_max=60.0, **SMALL), LINE3, BEND).integrate(rig, schedule)
    whole = StepModel.from_parts(linear_law(p_max=400.0, **SMALL), LINE3, BEND).integrate(rig, schedule)
    assert whole.stop_t is None and short.stop_t is not None
    near = whole.columns()["pressure_near_kpa"]
    t = schedule.time_s
    i = int(np.argmax(near >= 60.0))
    crossing = np.interp(60.0, near[i - 1:i + 1], t[i - 1:i + 1])
    assert short.stop_t == pytest.approx(crossing, abs=2e-5)
    rows = short.solved_rows
    assert rows == np.count_nonzero(t <= short.stop_t) and np.all(np.isnan(short.states[rows:]))
    a, b = short.columns(), whole.columns()
    assert np.max(np.abs(a["pressure_near_kpa"][:rows] - b["pressure_near_kpa"][:rows])) < 1e-3
    assert np.all(np.isnan(a["volume_ml"][rows:])) and np.max(a["pressure_near_kpa"][:rows]) <= 60.0
    assert short.stopped_by.startswith("chamber 1 reached 60 kPa, the last pressure the FE solved")


def test_a_stiffer_rubber_moves_the_end_with_its_pressures():
    """The law at modulus scale s is the nominal law at p / s: its end is at s times the nominal's."""
    model = StepModel.from_parts(linear_law(p_max=60.0, **SMALL), LINE3, BEND)
    run = model.integrate(Rig(150.0, tubing_length_mm=100.0), valve_schedule(None, 0.1, 5e-4), modulus_scale=1.5)
    cols = run.columns()
    assert run.stop_t is not None and np.nanmax(cols["pressure_near_kpa"]) <= 90.0 + 1e-9
    assert "reached 90 kPa (the design's rubber's 60 kPa x modulus scale 1.5)" in run.stopped_by


def test_a_bend_that_overshoots_past_the_laws_last_angle_ends_the_response():
    """Supply below the law's last pressure, but the lightly damped bend overshoots its last angle: the
    hold law is not read past it either."""
    law = linear_law(p_max=60.0, deg_per_kpa=3.0, **SMALL)  # 180 deg at 60 kPa
    light = BendingDynamics(mass_kg=BEND.mass_kg, length_m=BEND.length_m, moment_per_pa=BEND.moment_per_pa,
                            damping_ratio=0.05)
    res = simulate_step(law, LINE3, light, Rig(57.0, tubing_length_mm=100.0), duration_s=0.5)
    assert res.info["stopped_by"] is not None and "the bend reached 180.0 deg, the last the FE solved" in res.reason
    assert np.max(res["bend_angle_deg"]) <= 180.0 + 1e-9 and np.max(res.chamber_pressure_kpa) < 60.0
    assert res.info["full_bend_pressure_kpa"] is None


def test_step_model_run_answers_nan_past_the_end():
    """What the diagnosis reads: rows after the law's end are NaN (out of reach), the ones before finite."""
    t = np.arange(0.0, 0.1, 1e-3)
    protocol = StepProtocol(t, np.array([0.0, 0.1]), np.array([0]), 100.0, tubing_length_mm=100.0)
    out = StepModel.from_parts(linear_law(p_max=60.0, **SMALL), LINE3, BEND).run(protocol)
    finite = np.isfinite(out["pressure_far_kpa"])
    assert 0 < finite.sum() < t.size and np.all(finite[:finite.sum()])
    assert all(np.all(np.isnan(out[k][finite.sum():])) for k in out)


def test_the_fpn_at_345_kpa_ends_where_its_fe_curve_ended():
    """The fPN's FE curve ends at full bend (46.5 kPa): its near chamber passes that long before the lagging
    bend reaches 360 degrees, so the step model answers with that end, not with a volume drawn past it."""
    fpn = load_design("fpn")
    law = chamber_law_for(fpn)
    res = simulate_step(law, ActuatorLine.from_design(fpn), BendingDynamics.from_design(fpn), Rig(345.0),
                        duration_s=0.5)
    assert law.end.stop == "full_bend" and res.info["full_bend_pressure_kpa"] == pytest.approx(44.71, abs=0.01)
    assert res.time_to_full_bend_s is None and "chamber 1 reached 46.5 kPa" in res.reason
    assert np.max(res.chamber_pressure_kpa) <= law.top_kpa * (1 + 1e-9)


@pytest.mark.parametrize(("name", "ended", "cap"), [("spn", "pressure_maximum", False), ("fpn", "full_bend", False),
                                                    ("fig-s2c-w2", "pressure_limit", True)])
def test_a_characterisation_says_how_it_ended(name, ended, cap):
    from pnmold.physics.characterise import characterise

    c = characterise(load_design(name))
    assert c.how_ended == ended and c.ends_at_cap is cap and c.end_reason
    assert Characterisation.from_json({**c.to_json(), "stop": "stretch_limit"}).how_ended == "stretch_limit"


def test_a_characterisation_ended_at_its_cap_is_solved_on_up_to_the_pressure_asked_for(monkeypatch):
    """Ended merely at the cap below full bend: the FE solves on (another pressure limit, rounded up);
    ended at full bend or a physical stop: the law answers with that end, no FE."""
    ch = importlib.import_module("pnmold.physics.characterise")  # the module (the package exports the function)

    calls = []
    real = ch.characterise

    def fake(design, *, size=None, max_pressure_kpa=ch.DEFAULT_MAX_PRESSURE_KPA, progress=None, variants=True):
        calls.append((design.name, max_pressure_kpa, variants))
        return real(design, size=size, progress=progress) if max_pressure_kpa == ch.DEFAULT_MAX_PRESSURE_KPA \
            else "solved on"

    monkeypatch.setattr(ch, "characterise", fake)
    assert ch.characterise_up_to(load_design("fig-s2c-w2"), 345.0) == "solved on"
    assert calls[-1] == ("fig-s2c-w2", 350.0, False)
    assert ch.characterise_up_to(load_design("fig-s2c-w2"), 120.0).how_ended == "pressure_limit"  # within: as it is
    assert ch.characterise_up_to(SPN, 345.0).how_ended == "pressure_maximum"
    assert ch.characterise_up_to(load_design("fpn"), 345.0).how_ended == "full_bend"
    assert [c[1] for c in calls] == [150.0, 350.0, 150.0, 150.0, 150.0]


def test_the_diagnosis_says_rows_past_the_fes_last_step_are_held_there_and_refuses_most_past_a_cap():
    """The reduced model holds rows past the FE's last solved step at that step (``pressure_excess``);
    the diagnosis says so by how the FE's curve ended, and refuses when most rows lie past a mere cap."""
    from pnmold.diagnose import Reach
    from pnmold.diagnose.data import build_dataset
    from pnmold.diagnose.reach import extrapolation
    from pnmold.errors import SolveError
    from tests.test_diagnose_reach import TOP, recording, toy_with_maximum

    rec = recording(1.7, 5)
    few = toy_with_maximum({}, {"modulus_scale": 1.7})  # a few top rows past the end
    data = build_dataset([rec], [few], 0.01)
    ended = Reach(TOP, 19.0, "the FE's curve ends at full bend (360 deg at 19 kPa): the free end meets the clamped "
                  "end", "full_bend")
    [note] = extrapolation([few], data, ended, 1.7)
    assert "rows lie past the last pressure the FE solved" in note and "held at that last state" in note
    assert "pressure maximum" not in note and "extrapolat" not in note
    [at_max] = extrapolation([few], data, Reach(TOP, None, "pressure maximum of the toy", "pressure_maximum"), 1.7)
    assert "past the model's pressure maximum" in at_max
    most = toy_with_maximum({}, {"modulus_scale": 1.0})  # half the rows past the end
    capped = Reach(TOP, None, f"bend angle reached 300 deg at the pressure limit {TOP:g} kPa", "pressure_limit")
    with pytest.raises(SolveError, match="the model reads no law past the FE's last solved step"):
        extrapolation([most], build_dataset([rec], [most], 0.01), capped)
