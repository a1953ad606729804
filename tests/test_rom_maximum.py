"""The reduced model of a design whose FE stopped at a pressure maximum (a limit point): no law is
read past it. Rows beyond it have no equilibrium under pressure control; the model gives the state
at the maximum (the nearest it comes) and says how far out of reach they are, instead of
extrapolating the last, nearly vertical, slope of the curve."""

from __future__ import annotations

import json
from dataclasses import fields, replace

import numpy as np
import pytest

from pnmold.design import load_design
from pnmold.errors import SolveError
from pnmold.physics import Characterisation, Protocol, ReducedModel
from pnmold.physics.characterisation import CURVES, ROD


def _bundled_fpn() -> tuple[object, Characterisation]:
    from pnmold.physics.characterise import BUNDLED_DIR, DEFAULT_MAX_PRESSURE_KPA, DEFAULT_SIZE, cache_path

    design = load_design("fpn")
    path = BUNDLED_DIR / cache_path(design, DEFAULT_SIZE, DEFAULT_MAX_PRESSURE_KPA).name
    return design, Characterisation.from_json(json.loads(path.read_text()))


def _ending_at(c: Characterisation, steps: int, reason: str) -> Characterisation:
    """The first ``steps`` of ``c``, as if its free run had stopped there for ``reason``."""
    cut = {f.name: getattr(c, f.name)[:steps] for f in fields(c) if f.name in (*CURVES, *ROD[1:])}
    return replace(c, **cut, full_bend_pressure_kpa=None, reason=reason, variants={})


def _steps_below(c: Characterisation, kpa: float) -> tuple[int, float]:
    """How many of ``c``'s steps lie below ``kpa``, and the last one's pressure."""
    steps = int(np.searchsorted(c.pressure_kpa, kpa))
    return steps, float(c.pressure_kpa[steps - 1])


@pytest.fixture(scope="module")
def models():
    design, full = _bundled_fpn()
    steps, top = _steps_below(full, 30.0)
    maximum = _ending_at(full, steps, f"pressure maximum of {top:.4g} kPa at 200.0 deg bend and 9 mL: past it ...")
    limit = _ending_at(full, steps, f"bend angle reached 200 deg at the pressure limit {top:.4g} kPa")
    return ReducedModel(design, maximum), ReducedModel(design, limit), top


def test_only_a_pressure_maximum_ends_the_law(models):
    at_max, at_limit, _ = models
    assert at_max.characterisation.ends_at_pressure_maximum
    assert not at_limit.characterisation.ends_at_pressure_maximum
    _, full = _bundled_fpn()
    assert not full.ends_at_pressure_maximum  # the fPN reaches full bend


def test_rows_past_a_pressure_maximum_have_no_equilibrium_and_say_how_far(models):
    at_max, at_limit, top = models
    p = np.array([0.0, 0.5 * top, 0.99 * top, 1.25 * top, 2.0 * top])
    protocol = Protocol("bending", p, "none")
    out = at_max.run(protocol, {"gravity": 0.0}, partial=True)
    below = p <= top
    # below the maximum: the same law as a run that stopped at its pressure limit there
    same = at_limit.run(protocol, {"gravity": 0.0}, partial=True)
    at_top = at_limit.run(Protocol("bending", np.array([top]), "none"), {"gravity": 0.0})
    linear = at_limit.tables.angle[-1] + (p[-1] - top) * (at_limit.tables.angle[-1] - at_limit.tables.angle[-2]) / (
        at_limit.tables.p[-1] - at_limit.tables.p[-2])  # what the last slope's extrapolation would say
    for key in ("bend_angle_deg", "tip_x_mm", "tip_z_mm", "cavity_volume_ml"):
        assert np.allclose(out[key][below], same[key][below]), key
        # past it: the state at the maximum, the nearest the model comes (not the last slope's extrapolation)
        assert np.allclose(out[key][~below], at_top[key][0]), key
        # a run that stopped at its pressure limit is not read past it either (issue 43): the same state
        assert np.allclose(same[key][~below], at_top[key][0]), key
    assert np.degrees(linear[-1]) > at_top["bend_angle_deg"][0] + 20  # which it no longer is
    # past it: the share of the row's pressure the model cannot hold, 1 - p_max / p
    expected = np.zeros(p.size)
    expected[~below] = 1.0 - top / p[~below]
    assert out["pressure_excess"] == pytest.approx(expected, abs=1e-12)
    assert same["pressure_excess"] == pytest.approx(expected, abs=1e-12)
    assert np.all(out["beyond_fe"] == ~below) and np.all(same["beyond_fe"] == ~below)
    with pytest.raises(SolveError, match=r"fpn at .* kPa lies past the last pressure the FE solved .*pressure limit"):
        at_limit.run(protocol, {"gravity": 0.0})


def test_the_modulus_scale_moves_the_maximum_with_it(models):
    at_max, _, top = models
    p = np.array([0.0, 1.5 * top, 1.9 * top])
    out = at_max.run(Protocol("pv", p, "none"), {"gravity": 0.0}, calibration={"modulus_scale": 2.0}, partial=True)
    assert np.all(out["pressure_excess"] == 0.0) and np.all(np.diff(out["volume_ml"]) > 0)
    soft = at_max.run(Protocol("pv", p, "none"), {"gravity": 0.0}, calibration={"modulus_scale": 1.6}, partial=True)
    assert soft["pressure_excess"][2] == pytest.approx(1.0 - 1.6 * top / (1.9 * top))
    assert soft["pressure_excess"][1] == 0.0


def test_without_partial_a_row_past_the_maximum_is_an_error_naming_it(models):
    at_max, _, top = models
    with pytest.raises(SolveError, match=r"no equilibrium of fpn at .* kPa: beyond the FE's pressure maximum"):
        at_max.run(Protocol("bending", np.array([0.0, 1.5 * top]), "none"), {"gravity": 0.0})


def test_simulate_leaves_out_the_rows_past_the_maximum_and_says_why(models):
    """``pnmold simulate --model rom`` on such a design: the rows up to the maximum, then the reason;
    before, the rows past it were the last slope's extrapolation, hundreds of degrees."""
    from pnmold.simulate import SimulationRequest, simulate_rom

    at_max, at_limit, top = models
    pressures = (0.0, 0.5 * top, 0.9 * top, 1.2 * top, 1.5 * top)
    doc = simulate_rom(at_max.design, SimulationRequest(pressures, model="rom", orientation="chambers_up"),
                       at_max.characterisation)
    assert [s["pressure_kpa"] for s in doc["steps"]] == pytest.approx(pressures[:3])
    assert doc["full_bend_pressure_kpa"] is None
    assert doc["reason"].startswith("pressure maximum of") and "2 of 5 rows lie past it" in doc["reason"]
    full = simulate_rom(at_limit.design, SimulationRequest(pressures, model="rom", orientation="chambers_up"),
                        at_limit.characterisation)
    # a run that stopped at its pressure limit: not read on past it either (issue 43), said
    assert len(full["steps"]) == 3
    assert full["reason"].startswith("2 of 5 rows lie past the last pressure the FE solved") and \
        "at the pressure limit" in full["reason"]


def test_a_simulation_stops_at_full_bend_the_physical_stop():
    """Pressures far past full bend (a GPa once gave 9 million degrees) give no row past 360 degrees;
    the rows below are as a run that stopped before, and the reason names the stop."""
    from pnmold.simulate import SimulationRequest, simulate_rom

    design, c = _bundled_fpn()
    far = simulate_rom(design, SimulationRequest((0.0, 20.0, 40.0, 1e3, 1e6), model="rom"), c)
    near = simulate_rom(design, SimulationRequest((0.0, 20.0, 40.0), model="rom"), c)
    assert [s["pressure_kpa"] for s in far["steps"]] == [0.0, 20.0, 40.0]
    assert far["steps"] == near["steps"]
    assert max(s["bend_angle_deg"] for s in far["steps"]) <= 360.0
    assert "2 of 5 rows lie past the last pressure the FE solved (46.5 kPa" in far["reason"]
    assert "ends at full bend" in far["reason"] and "the free end meets the clamped end" in far["reason"]
