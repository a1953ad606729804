"""The diagnosis machinery on a toy model with known answers: calibrate first, do not blame
a plain stiffness error on physics, say nothing on clean data, name a concealed term."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from pnmold.diagnose import DesignRef, DiagnosisModel, Reach, diagnose
from pnmold.diagnose.data import noise_sigma
from pnmold.recording import Recording


@dataclass(frozen=True)
class ToyEffect:
    name: str
    parameter: str
    unit: str
    bounds: tuple[float, float]
    kinds: tuple[str, ...] = ("bending",)
    extra: tuple = ()
    description: str = "A toy term."
    fingerprint: str = "Toy fingerprint."


EFFECTS = [ToyEffect("sag", "g", "1", (0.0, 3.0)), ToyEffect("stiffening", "k", "1/kPa^2", (0.0, 4e-4)),
           ToyEffect("creep", "c", "mm", (0.0, 5.0))]
P = np.concatenate([np.linspace(0, 40, 41), np.linspace(40, 0, 41)])
PHASE = np.array(["inflate"] * 41 + ["deflate"] * 41)


def toy(effects: dict, calib: dict, p=P, phase=PHASE) -> dict[str, np.ndarray]:
    s = calib.get("modulus_scale", 1.0)
    bend = 0.02 * p / s * (1.0 - effects.get("stiffening", 0.0) * p ** 2)
    bend = bend + np.where(phase == "deflate", 0.01 * effects.get("creep", 0.0), 0.0)
    sag = effects.get("sag", 0.0) * 4.0 / (1.0 + bend * 5)
    return {"tip_x_mm": 100.0 * np.cos(bend) - 2.0 * p / 40, "tip_z_mm": -100.0 * np.sin(bend) - sag}


def recording(effects: dict, scale: float, noise_mm: float, seed: int) -> Recording:
    rng = np.random.default_rng(seed)
    cols = toy(effects, {"modulus_scale": scale})
    cols = {k: v + rng.normal(0, noise_mm, v.size) for k, v in cols.items()}
    return Recording("toy.csv", "bending", {"pressure_kpa": P, "phase": PHASE, **cols},
                     {"orientation": "chambers_up"})


def forward(effects, calib):
    return [toy(effects, calib)]


def run(rec):
    """The toy model is the truth: no form error under the noise."""
    return diagnose(DesignRef("toy", "0"), [rec], DiagnosisModel(forward, EFFECTS, bootstrap_seed=1,
                                                                  model_form_share=0.0, pressure_form_share=0.0))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_nothing_is_claimed_on_clean_data_with_a_stiffness_error(seed):
    diag = run(recording({}, scale=1.15, noise_mm=0.2, seed=seed))
    assert diag.named == [] and not diag.doc["unexplained"]
    assert diag.doc["baseline"]["calibrated"]["modulus_scale"] == pytest.approx(1.15, rel=0.02)


@pytest.mark.parametrize("effect,value", [("sag", 1.0), ("stiffening", 2e-4), ("creep", 2.0)])
def test_a_concealed_term_is_named_with_its_value(effect, value):
    diag = run(recording({effect: value}, scale=0.9, noise_mm=0.2, seed=7))
    assert diag.named == [effect]
    found = diag.doc["missing_physics"][0]["parameters"][effect]
    assert found == pytest.approx(value, rel=0.2)
    fit = diag.doc["fit"]
    assert fit["heldout_rmse_after"] * 3 < fit["heldout_rmse_before"]
    assert diag.doc["mismatch"] and diag.doc["mismatch"][0]["significance"] > 4


def test_structure_no_term_explains_is_called_unexplained():
    rec = recording({}, scale=1.0, noise_mm=0.2, seed=3)
    rec.columns["tip_z_mm"] = rec.columns["tip_z_mm"] + 3.0 * np.sin(P / 3.0)  # a wobble nothing models
    diag = run(rec)
    assert diag.doc["unexplained"] is True
    # the summary points at what lies outside the catalogue, the design's own geometry first
    assert "not the actuator as built" in diag.doc["summary"] and "design.toml" in diag.doc["summary"]


def test_a_diagnosis_shows_itself_in_one_or_two_short_lines():
    """A notebook's cell shows the design, the recordings, the named effect with its value, the verdict
    and the held-out error before and after, not the whole document."""
    diag = run(recording({"sag": 1.0}, scale=0.9, noise_mm=0.2, seed=7))
    text = repr(diag)
    assert len(text) < 400 and text.count("\n") <= 1
    assert text.startswith("<Diagnosis toy: bending (82 rows); named sag = ") and "unexplained no" in text
    fit = diag.doc["fit"]
    assert (f"held-out RMSE {fit['heldout_rmse_before']:.3g} -> {fit['heldout_rmse_after']:.3g} mm "
            f"({fit['observable']})") in text


def test_a_diagnosis_shows_itself_as_an_escaped_table_in_a_notebook():
    rec = recording({"sag": 1.0}, scale=0.9, noise_mm=0.2, seed=7)
    diag = diagnose(DesignRef("<toy & co>", "0"), [rec], DiagnosisModel(forward, EFFECTS, bootstrap_seed=1,
                                                                         model_form_share=0.0,
                                                                         pressure_form_share=0.0))
    page = diag._repr_html_()
    assert page.startswith("<table>") and "</table>" in page and "<td style='text-align:left'>sag = " in page
    assert "&lt;toy &amp; co&gt;" in page and "<toy" not in page
    assert "held-out RMSE" in page and "-&gt;" in page and "->" not in page  # every string escaped
    assert "The model left out a toy term (sag)" in page  # the summary sentence


def test_a_diagnosis_draws_its_figure_without_writing_a_file(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    monkeypatch.chdir(tmp_path)
    diag = run(recording({"sag": 1.0}, scale=0.9, noise_mm=0.2, seed=7))
    fig = diag.figure()
    assert isinstance(fig, Figure) and len(fig.axes) == 2 * len(diag.data.series)
    assert all(ax.lines for ax in fig.axes) and list(tmp_path.iterdir()) == []
    given = Figure()
    axes = given.subplots(2, len(diag.data.series))
    assert diag.figure(ax=axes) is given and axes[0, 0].lines


def test_noise_is_estimated_from_the_data():
    rng = np.random.default_rng(0)
    x = np.linspace(0, 1, 400)
    r = 0.5 * x ** 2 + rng.normal(0, 0.3, x.size)
    assert noise_sigma(r, np.zeros(x.size, int), 1e-9) == pytest.approx(0.3, rel=0.15)


def test_a_prediction_at_parameters_already_run_is_not_run_again():
    """The fitter keeps each forward result by its exact parameters: the same parameters give the
    same prediction (and the same failure) without another model run; other parameters run."""
    from pnmold.diagnose.data import build_dataset
    from pnmold.diagnose.decide import hypothesis
    from pnmold.diagnose.fitting import Fitter
    from pnmold.errors import SolveError

    runs = []

    def forward(effects, calib):
        runs.append((dict(effects), dict(calib)))
        if effects.get("sag", 0.0) > 2.0:
            raise SolveError("no equilibrium")
        return [toy(effects, calib)]

    rec = Recording("toy.csv", "bending", {"pressure_kpa": P, "phase": PHASE, **toy({}, {})}, {})
    fitter = Fitter(build_dataset([rec], forward({}, {})), forward)
    runs.clear()
    h = hypothesis([EFFECTS[0]])  # modulus_scale, sag
    first = fitter.predict(h, np.array([1.0, 0.5]))
    assert fitter.predict(h, np.array([1.0, 0.5])) is first and len(runs) == 1 == fitter.evaluations
    fitter.predict(h, np.array([1.0, 0.6]))
    assert len(runs) == 2 == fitter.evaluations
    for _ in range(2):
        with pytest.raises(SolveError):
            fitter.predict(h, np.array([1.0, 2.5]))
    assert len(runs) == 3 == fitter.evaluations


def test_without_repeated_cycles_the_floor_follows_the_models_slope_in_pressure():
    """Each row's floor is the range share plus the model's pressure error carried through its slope
    (largest where the bend runs away at a flat pressure); repeated cycles measure the rig's scatter,
    not the model's distance from the actuator: the floor stands beside them."""
    from pnmold.diagnose.data import PRESSURE_FORM_SHARE, build_dataset

    p = np.linspace(0.0, 30.0, 16)
    bend = 10.0 * np.tan(np.radians(2.8 * p))  # steepening toward 84 degrees of tan's argument
    rec = Recording("ramp.csv", "bending", {"pressure_kpa": p, "bend_angle_deg": bend}, {})
    (s,) = build_dataset([rec], [{"bend_angle_deg": bend}], model_form_share=0.01).series
    slope = np.gradient(bend, p)
    expected = np.hypot(0.01 * np.ptp(bend), PRESSURE_FORM_SHARE * p * np.abs(slope))
    assert s.sigma == pytest.approx(np.hypot(s.measurement, expected), rel=1e-9)
    assert s.sigma[-1] > 5 * s.sigma[1]  # the steep end is held to its pressure, not to the range
    (flat,) = build_dataset([rec], [{"bend_angle_deg": bend}], 0.01, pressure_form_share=0.0).series
    assert flat.sigma == pytest.approx(np.hypot(flat.measurement, 0.01 * np.ptp(bend)))
    cycles = np.repeat([1, 2, 3], p.size)
    phases = np.array(["inflate"] * p.size * 3)
    repeated = Recording("cycles.csv", "bending", {"pressure_kpa": np.tile(p, 3), "bend_angle_deg": np.tile(bend, 3),
                                                  "cycle": cycles, "phase": phases}, {})
    (r,) = build_dataset([repeated], [{"bend_angle_deg": np.tile(bend, 3)}], 0.01).series
    assert r.model_form > 0.01 * np.ptp(bend)
    assert r.sigma == pytest.approx(np.hypot(r.measurement, np.tile(expected, 3)), rel=1e-5)



def _reaching(top_kpa: float):
    """The toy's forward model with an FE characterisation that stopped at ``top_kpa`` (design's
    rubber): rows past it, in the recording's pressure, are marked as the reduced model marks them."""
    def forward(effects, calib):
        out = toy(effects, calib)
        out["beyond_fe"] = P / calib.get("modulus_scale", 1.0) > top_kpa * 1.01
        return [out]
    return forward


REASON = "pressure maximum of the toy"


def test_rows_beyond_the_fe_are_said_at_the_recordings_pressure():
    rec = recording({}, scale=1.15, noise_mm=0.2, seed=2)
    diag = diagnose(DesignRef("toy", "0"), [rec],
                    DiagnosisModel(_reaching(32.0), EFFECTS, reach=Reach(32.0, None, REASON), bootstrap_seed=1,
                                   model_form_share=0.0, pressure_form_share=0.0))
    scale = diag.doc["calibration"]["final"]["modulus_scale"]
    [note] = [n for n in diag.doc["calibration"]["notes"] if "beyond the pressure the FE characterised" in n]
    expected = int(np.sum(P / scale > 32.0 * 1.01))
    assert note.startswith(f"{expected} of {P.size} rows") and 0 < expected <= 0.2 * P.size
    assert f"{32.0 * scale:.4g} kPa of the recordings (32 kPa with the design's rubber" in note


def test_most_rows_beyond_a_stopped_fe_are_refused_naming_the_recordings_pressure():
    from pnmold.errors import SolveError

    rec = recording({}, scale=1.15, noise_mm=0.2, seed=2)
    with pytest.raises(SolveError, match=r"rows need the model beyond 2[89]\.\d+ kPa of the recordings \(25 kPa"):
        diagnose(DesignRef("toy", "0"), [rec],
                 DiagnosisModel(_reaching(25.0), EFFECTS, reach=Reach(25.0, None, REASON), bootstrap_seed=1,
                                model_form_share=0.0, pressure_form_share=0.0))


def test_held_out_rows_a_fold_extrapolates_are_judged_against_the_predictions_own_spread():
    """One short ramp, the stiffening showing mostly at its top: the fold without the top rows barely
    pins it, so its prediction there carries a wide spread (linearised, the parameters' prior their
    bounds); the verdict judges held-out rows against that spread, not against the noise alone. Rows
    a fold's parameters pin (mid-ramp) keep nearly their plain score."""
    from pnmold.diagnose.data import build_dataset
    from pnmold.diagnose.decide import hypothesis, judge, predictive_z, starts_for
    from pnmold.diagnose.fitting import Fitter

    p = np.linspace(0.0, 40.0, 15)
    phase = np.array(["inflate"] * p.size)
    truth = toy({"stiffening": 2e-4}, {}, p=p, phase=phase)
    rng = np.random.default_rng(2)
    rec = Recording("ramp.csv", "bending", {"pressure_kpa": p, "phase": phase,
                                            **{k: v + rng.normal(0, 0.2, p.size) for k, v in truth.items()}}, {})

    def ramp(effects, calib):
        return [toy(effects, calib, p=p, phase=phase)]

    fitter = Fitter(build_dataset([rec], ramp({}, {}), 0.0, pressure_form_share=0.0), ramp)
    h = hypothesis([EFFECTS[1]])
    cand = judge(fitter, h, starts_for(h))
    plain, spread = np.abs(cand.heldout_z), np.abs(predictive_z(fitter, cand))
    assert np.all(spread <= plain + 1e-12)
    block = np.tile(fitter.data.series[0].block, 2)  # tip x and z
    shrink = {b: float(np.sum(spread[block == b] ** 2) / np.sum(plain[block == b] ** 2)) for b in np.unique(block)}
    assert shrink[max(shrink)] < 0.5 < shrink[2]  # the top block's extrapolation; mid-ramp nearly as it was


def test_an_effect_named_on_too_few_rows_for_two_folds_has_no_spread_and_valid_json(tmp_path):
    """Six rows of a bending ramp with a weight other than declared: the effect is named, its spread over the
    held-out folds cannot be measured (one fold), so it is null in the JSON and said in words, not NaN (which
    no JSON reader takes: the diagnosis used to stop with an unexpected error)."""
    import json

    from pnmold.cli import main

    rec, out = tmp_path / "few.csv", tmp_path / "few.json"
    assert main(["simulate", "fpn", "--model", "rom", "--kind", "bending", "--pressures", "0:20:5", "--effects",
                 "gravity=0.3", "--recording", str(rec), "--noise-mm", "0.2", "--seed", "2", "--quiet"]) == 0
    assert main(["diagnose", "fpn", str(rec), "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    named = {m["effect"]: m for m in d["missing_physics"]}
    assert named["gravity"]["uncertainty"] == {"gravity": None}
    assert "spread not measured" in named["gravity"]["explanation"]
