"""The stiffening ladder: a design whose free run ends at a pressure maximum is read, for a stiffer
rubber (Yeoh C30 added), off the FE's own runs with that rubber, which go on past the nominal's
maximum; between two runs the curves are interpolated at the same share of each run's final bend.

The runs here are made from the fPN's bundled FE curve (its first steps stand for a nominal that
stops at a maximum, longer stretches of it at raised pressures for the stiffer runs), so that what
the model must reproduce is known exactly."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pnmold.errors import DesignError
from pnmold.physics import Characterisation, Protocol, ReducedModel
from pnmold.physics.characterisation import CURVES
from pnmold.physics.characterise import LADDER_EFFECT
from tests.test_rom_maximum import _bundled_fpn, _ending_at, _steps_below

#: the runs: C30 (MPa) -> (the fPN's steps up to this pressure, their pressures raised by this factor)
RUNGS = {0.001: (40.0, 1.10), 0.003: (50.0, 1.25)}


def _rung(full: Characterisation, upto_kpa: float, factor: float) -> dict[str, list[float]]:
    steps, _ = _steps_below(full, upto_kpa)
    curves = {k: [float(x) for x in getattr(full, k)[:steps]] for k in CURVES}
    curves["pressure_kpa"] = [factor * p for p in curves["pressure_kpa"]]
    return curves


@pytest.fixture(scope="module")
def ladder():
    design, full = _bundled_fpn()
    steps, top = _steps_below(full, 30.0)
    nominal = _ending_at(full, steps, f"pressure maximum of {top:.4g} kPa at 150.0 deg bend and 9 mL: past it ...")
    variants = {f"{LADDER_EFFECT}={v:g}": {"format": 2, "value": v, "stop": "pressure_maximum", **_rung(full, *spec)}
                for v, spec in RUNGS.items()}
    return design, full, ReducedModel(design, nominal), ReducedModel(design, replace(nominal, variants=variants))


def _free(model: ReducedModel, p: np.ndarray, c30: float = 0.0) -> dict[str, np.ndarray]:
    return model.run(Protocol("bending", p, "none"), {"gravity": 0.0, LADDER_EFFECT: c30}, partial=True)


def test_a_ladder_is_read_only_where_the_free_run_ends_at_a_maximum(ladder):
    design, full, plain, laddered = ladder
    assert not plain.ladder and [r["value"] for r in laddered.ladder] == [0.0, 0.001, 0.003]
    assert laddered.ladder_top_mpa == 0.003
    variants = dict(laddered.characterisation.variants)
    assert not ReducedModel(design, replace(full, variants=variants)).ladder  # the fPN reaches full bend


def test_without_c30_the_ladder_changes_nothing(ladder):
    _, _, plain, laddered = ladder
    p = np.linspace(0.0, 35.0, 9)
    a, b = _free(plain, p), _free(laddered, p)
    for key in ("bend_angle_deg", "tip_x_mm", "tip_z_mm", "cavity_volume_ml", "pressure_excess"):
        np.testing.assert_allclose(a[key], b[key])


@pytest.mark.parametrize("c30", list(RUNGS))
def test_at_a_runs_c30_the_model_follows_that_run_past_the_nominal_maximum(ladder, c30):
    _, full, _, laddered = ladder
    run = _rung(full, *RUNGS[c30])
    p, bend = np.array(run["pressure_kpa"]), np.array(run["bend_angle_deg"])
    inside = (p > 0) & (p < 0.995 * p[-1])
    out = _free(laddered, p[inside], c30)
    assert np.all(out["pressure_excess"] == 0)  # reached, where the nominal has no equilibrium
    # the share-of-bend grid (61 points) interpolates the run's own curve
    np.testing.assert_allclose(out["bend_angle_deg"], bend[inside], atol=0.02 * bend[-1])
    np.testing.assert_allclose(out["cavity_volume_ml"], np.array(run["cavity_volume_ml"])[inside],
                               rtol=0.03, atol=0.02 * run["cavity_volume_ml"][-1])


def test_between_runs_the_maximum_lies_between_theirs_and_past_it_rows_are_out_of_reach(ladder):
    _, full, _, laddered = ladder
    ends = {v: _rung(full, *spec) for v, spec in RUNGS.items()}
    between = laddered.laddered(0.002).characterisation
    p_lo, p_hi = ends[0.001]["pressure_kpa"][-1], ends[0.003]["pressure_kpa"][-1]
    b_lo, b_hi = ends[0.001]["bend_angle_deg"][-1], ends[0.003]["bend_angle_deg"][-1]
    assert p_lo < between.pressure_kpa[-1] < p_hi and b_lo < between.bend_angle_deg[-1] < b_hi
    assert between.ends_at_pressure_maximum
    top = float(between.pressure_kpa[-1])
    out = _free(laddered, np.array([0.5 * top, 0.98 * top, 1.2 * top]), 0.002)
    assert out["pressure_excess"][0] == 0 and out["pressure_excess"][1] == 0
    assert out["pressure_excess"][2] == pytest.approx(1 - 1 / 1.2, rel=1e-6)
    # more C30, more bend at the same pressure past the first run's reach: the order the runs give
    p = np.array([0.9 * p_lo])
    bends = [float(_free(laddered, p, c)["bend_angle_deg"][0]) for c in (0.001, 0.002, 0.003)]
    assert bends[0] > bends[1] > bends[2]  # stiffer: less bend at one pressure


def test_a_c30_outside_the_ladder_is_refused_by_name(ladder):
    *_, laddered = ladder
    with pytest.raises(DesignError, match=r"strain_stiffening\.c30_mpa"):
        laddered.laddered(0.01)


def test_the_diagnosis_fits_strain_stiffening_by_c30_on_a_ladder():
    from pnmold.diagnose.decide import LADDER_KEY, hypothesis, ladder_parameter
    from pnmold.effects import EFFECTS

    effect = EFFECTS["strain_stiffening"]
    assert ladder_parameter(0.0) == {}
    h = hypothesis([effect], main=ladder_parameter(0.003))
    keys = [p.key for p in h.parameters if not p.calibration]
    assert keys == [LADDER_KEY]
    (c30,) = [p for p in h.parameters if p.key == LADDER_KEY]
    assert (c30.low, c30.high) == (0.0, 0.003)
    assert [p.key for p in hypothesis([effect]).parameters if not p.calibration] == ["strain_stiffening"]


def test_past_a_run_that_ends_at_a_bifurcation_the_law_is_extrapolated_not_cut(ladder):
    """A run whose path meets a bifurcation (``instability``) with its pressure still rising has not
    reached a maximum: rows up to 10 % past its end read the law's last slope (flagged ``beyond_fe``),
    further ones have no equilibrium there; a run's own pressure maximum, or the nominal's, ends the law."""
    from pnmold.physics.rom import LADDER_EXTRAPOLATION

    design, full, _, laddered = ladder
    variants = {k: {**v, "stop": "instability"} if v["value"] == 0.003 else v
                for k, v in laddered.characterisation.variants.items()}
    model = ReducedModel(design, replace(laddered.characterisation, variants=variants))
    at_top = model.laddered(0.003).characterisation
    assert not at_top.ends_at_pressure_maximum and "critical point" in at_top.reason
    assert model.laddered(0.001).characterisation.ends_at_pressure_maximum  # both of its runs end at one
    top = float(at_top.pressure_kpa[-1])
    out = _free(model, np.array([0.5 * top, 1.05 * top, 1.3 * top]), 0.003)
    assert list(out["beyond_fe"]) == [False, True, True]
    assert out["pressure_excess"][0] == 0 and out["pressure_excess"][1] == 0
    assert out["pressure_excess"][2] == pytest.approx(1 - (1 + LADDER_EXTRAPOLATION) / 1.3, rel=1e-6)
    assert at_top.bend_angle_deg[-1] < out["bend_angle_deg"][1] < out["bend_angle_deg"][2]


def test_the_ladder_runs_each_c30_to_its_own_end_once_and_is_cached(tmp_path, monkeypatch):
    """``stiffening_ladder`` asks the FE for the missing runs only, each up to the pressure limit (not at
    the free run's pressures), keeps why each ended and writes them back to the cache."""
    import importlib
    import json

    ch = importlib.import_module("pnmold.physics.characterise")
    design, full = _bundled_fpn()
    steps, top = _steps_below(full, 30.0)
    nominal = replace(_ending_at(full, steps, f"pressure maximum of {top:.4g} kPa at 150.0 deg bend"), source="fe")
    monkeypatch.setenv("PNMOLD_CACHE", str(tmp_path))
    path = ch.cache_path(design, ch.DEFAULT_SIZE, ch.DEFAULT_MAX_PRESSURE_KPA)
    from pnmold.fsutil import write_json

    write_json(path, nominal.to_json())
    asked = []

    def fake_runs(design, size, missing, say, pressures_kpa=None, max_pressure_kpa=None):
        asked.append((list(missing), pressures_kpa, max_pressure_kpa))
        return {k: {"format": ch.VARIANT_FORMAT, "value": float(k.partition("=")[2]), "stop": "instability",
                    **_rung(full, 40.0, 1.1), "seconds": 2.0} for k in missing}

    monkeypatch.setattr(ch, "_run_variants", fake_runs)
    monkeypatch.setattr(ch, "variant_keys", lambda: [])  # the other variants are not this test's
    got = ch.stiffening_ladder(design)
    keys = ch.ladder_keys(design)
    assert asked == [(keys, None, ch.DEFAULT_MAX_PRESSURE_KPA)]
    assert [r["stop"] for r in got.variant_runs(LADDER_EFFECT)] == ["instability"] * 3
    assert sorted(json.loads(path.read_text())["variants"]) == sorted(keys)
    assert ReducedModel(design, got).ladder_top_mpa == pytest.approx(0.006 * design.material.c10_mpa, rel=1e-3)
    ch.stiffening_ladder(design)
    assert len(asked) == 1  # cached: nothing runs again
