"""The calibration against a model with a pressure maximum, and against an effect that only stands in
for the modulus: on the toy model of ``tests/test_diagnose_core.py`` with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from pnmold.diagnose import DesignRef, DiagnosisModel, Reach, diagnose
from pnmold.diagnose.data import build_dataset, pressure_form
from pnmold.recording import Recording
from tests.test_diagnose_core import EFFECTS, PHASE, P, ToyEffect, toy

#: the toy's pressure maximum with the design's rubber (kPa): past p / modulus_scale > TOP no equilibrium
TOP = 21.0


def toy_with_maximum(effects: dict, calib: dict) -> dict[str, np.ndarray]:
    """The toy with a limit point: rows past it at the state of the maximum, with the share of their
    pressure it cannot hold (as :meth:`pnmold.physics.rom.ReducedModel.run` gives them)."""
    scale = calib.get("modulus_scale", 1.0)
    read = P / scale
    excess = np.where(read > TOP, 1.0 - TOP / np.maximum(read, TOP), 0.0)
    out = toy(effects, calib, p=np.minimum(P, TOP * scale))
    return {**out, "pressure_excess": excess, "beyond_fe": excess > 0}


def toy_softening(effects: dict, calib: dict) -> dict[str, np.ndarray]:
    """The toy with an effect that, on these data, is the modulus itself: (1 + value) x the stiffness."""
    return toy(effects, {"modulus_scale": calib.get("modulus_scale", 1.0) * (1.0 + effects.get("softening", 0.0))})


def recording(scale: float, seed: int) -> Recording:
    rng = np.random.default_rng(seed)
    cols = {k: v + rng.normal(0, 0.2, v.size) for k, v in toy({}, {"modulus_scale": scale}).items()}
    return Recording("toy.csv", "bending", {"pressure_kpa": P, "phase": PHASE, **cols}, {"orientation": "chambers_up"})


REACH = Reach(max_pressure_kpa=TOP, full_bend_pressure_kpa=None, reason="pressure maximum of the toy")
TOY = DesignRef(name="toy", digest="0", material="toy rubber")


@pytest.mark.parametrize("scale", [2.0, 2.6])
def test_a_rubber_the_recordings_pressure_needs_is_found_not_refused(scale):
    """The recordings hold 40 kPa; the design's rubber has its maximum at 21: at least 1.9x stiffer.
    Before, rows past the maximum read the law's last slope (or were left out); now they count by
    how far out of reach they are, and the material check starts at the modulus that reaches them."""
    diag = diagnose(TOY, [recording(scale, 4)],
                    DiagnosisModel(lambda e, c: [toy_with_maximum(e, c)], EFFECTS, reach=REACH, bootstrap_seed=1))
    assert diag.doc["calibration"]["final"]["modulus_scale"] == pytest.approx(scale, rel=0.02)
    assert diag.named == [] and not diag.doc["unexplained"]
    check = diag.doc["calibration"]["material_check"]
    assert check["in_window"] is False and check["modulus_scale"] == pytest.approx(scale, rel=0.02)
    assert f"at least {40.0 / TOP * 1.001:.3g} times stiffer" in check["message"]
    assert not any(" rows lie " in n for n in diag.doc["calibration"]["notes"])  # every row reached


def test_rows_past_the_maximum_score_their_residual_at_the_maximum_and_their_pressure_shortfall():
    """At modulus 1.5 the toy reaches 31.5 kPa of the recording's 40: the rows above count their
    residual against the state at the maximum and, in quadrature, their pressure shortfall over the
    model's 2 % form error in pressure."""
    from pnmold.diagnose.fitting import zscores

    rec = recording(1.7, 5)
    data = build_dataset([rec], [toy_with_maximum({}, {"modulus_scale": 1.5})], 0.01)
    pred = toy_with_maximum({}, {"modulus_scale": 1.5})
    z = zscores(data, [pred])
    past = pred["pressure_excess"] > 0
    plain = np.concatenate([(s.y - pred[s.observable]) / s.sigma for s in data.series])
    reach = np.tile(pred["pressure_excess"], 2) / data.series[0].pressure_share
    assert past.any() and np.all(np.isfinite(z))
    assert np.abs(z) == pytest.approx(np.hypot(plain, reach))  # continuous at the maximum, growing past it
    assert np.all(np.sign(z[plain != 0]) == np.sign(plain[plain != 0]))


def test_an_effect_that_only_stands_in_for_the_modulus_is_not_named():
    """On one loading an effect that multiplies the stiffness is the modulus: when the recordings need
    a rubber outside the window, the effect must not be named for freeing it (docs/diagnosis.md: judge a term
    only by what recalibration could not absorb); the other rubber is said instead."""
    softening = ToyEffect("softening", "s", "1", (0.0, 0.5))
    diag = diagnose(TOY, [recording(2.2, 6)],
                    DiagnosisModel(lambda e, c: [toy_softening(e, c)], [*EFFECTS, softening], bootstrap_seed=1,
                                   model_form_share=0.0, pressure_form_share=0.0))
    assert "softening" not in diag.named
    assert diag.doc["calibration"]["material_check"]["modulus_scale"] == pytest.approx(2.2, rel=0.02)


def test_a_short_ramp_is_held_out_in_as_many_blocks_as_folds():
    p = np.linspace(0.0, 30.0, 15)
    rec = Recording("ramp.csv", "bending", {"pressure_kpa": p, "bend_angle_deg": p ** 1.5}, {})
    (s,) = build_dataset([rec], [{"bend_angle_deg": p ** 1.5}]).series
    assert np.unique(s.block).size == 5 and np.unique(s.block % 5).size == 5
    assert np.all(np.diff(s.block) >= 0)  # contiguous rows, never single rows dealt round


def test_where_the_model_has_no_equilibrium_the_floor_follows_the_recordings_slope():
    p = np.linspace(0.0, 30.0, 16)
    measured = 2.0 * p + 0.1 * p ** 2
    model = np.where(p > 20.0, np.nan, 2.0 * p)
    rec = Recording("ramp.csv", "bending", {"pressure_kpa": p, "bend_angle_deg": measured}, {})
    form = pressure_form(rec, model, np.zeros(p.size, int), 0.02, measured)
    on = p <= 20.0
    assert form[on] == pytest.approx(0.02 * p[on] * 2.0)
    assert form[~on] == pytest.approx(0.02 * p[~on] * np.abs(np.gradient(measured, p))[~on])


def test_rows_past_the_baselines_maximum_take_the_recordings_slope_in_the_floor():
    """Past its pressure maximum the model gives the state at the maximum, constant in pressure: its
    slope (zero) would leave those rows with no pressure form error at all, exactly where the bend runs
    away at a nearly flat pressure. The recording's own slope stands in, as where the model has no
    equilibrium."""
    p = np.linspace(0.0, 30.0, 16)
    measured = 2.0 * p + 0.1 * p ** 2
    past = p > 20.0
    at_maximum = np.where(past, 40.0, 2.0 * p)
    rec = Recording("ramp.csv", "bending", {"pressure_kpa": p, "bend_angle_deg": measured}, {})
    baseline = {"bend_angle_deg": at_maximum, "pressure_excess": np.where(past, 1.0 - 20.0 / np.maximum(p, 20.0), 0.0)}
    (s,) = build_dataset([rec], [baseline], model_form_share=0.0).series
    floor = np.sqrt(s.sigma ** 2 - s.measurement ** 2)
    assert floor[~past] == pytest.approx(0.02 * p[~past] * 2.0)
    assert floor[past] == pytest.approx(0.02 * p[past] * np.abs(np.gradient(measured, p))[past])
