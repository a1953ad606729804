"""The FE's effect responses as pressure factors (pnmold.physics.response) and the reduced
model reading them: exact on curves made by scaling the pressure of the stored fPN steps, so
any error here is the module's, not the FE's. Against live FE runs: tests/test_rom.py."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pnmold.physics import Protocol, ReducedModel, characterisation_from_steps
from pnmold.physics.response import Factor, Response, equivalent_pressure, responses, solve_stiffened
from tests.conftest import STEPS

OFF = {"gravity": 0.0}


def _base():
    p = np.linspace(0.0, 40.0, 41)
    return {"pressure_kpa": p, "bend_angle_deg": 9.0 * p + 0.05 * p ** 2, "cavity_volume_ml": 10 + 0.1 * p,
            "tip_x_mm": 100.0 - 0.5 * p, "tip_z_mm": -1.5 * p, "clamp_x_mm": 10.0}


def test_equivalent_pressure_inverts_the_nominal_curve_and_refuses_beyond_it():
    b = _base()
    q = equivalent_pressure(b["pressure_kpa"], b["bend_angle_deg"], np.interp([5.0, 12.5, 50.0], b["pressure_kpa"],
                                                                              b["bend_angle_deg"]))
    assert q[:2] == pytest.approx([5.0, 12.5], abs=0.02)
    assert np.isnan(equivalent_pressure(b["pressure_kpa"], b["bend_angle_deg"], np.array([1e4])))[0]
    stalled = b["bend_angle_deg"].copy()
    stalled[20:] = stalled[20]  # a stalled solve repeats its last bend: skipped, not inverted
    assert equivalent_pressure(b["pressure_kpa"], stalled, np.array([stalled[10]]))[0] == pytest.approx(10.0)


@pytest.mark.parametrize("softening", [True, False])
def test_factors_recover_a_known_pressure_scale_for_shape_and_volume(softening):
    b = _base()
    p = np.linspace(0.0, 30.0, 16)
    k_bend, k_vol = 1.25, 1.1  # the variant looks like the nominal at k x p (softening) or p / k (stiffening)

    def at(scale, name):
        return np.interp(p * scale, b["pressure_kpa"], b[name])

    k = {True: (k_bend, k_vol), False: (1 / k_bend, 1 / k_vol)}[softening]
    variant = {"pressure_kpa": p, "bend_angle_deg": at(k[0], "bend_angle_deg"),
               "cavity_volume_ml": at(k[1], "cavity_volume_ml"),
               "tip_x_mm": at(k[0], "tip_x_mm"), "tip_z_mm": at(k[0], "tip_z_mm")}  # the tip follows the bend
    f = responses(b, [(2.0, variant)], softening)
    grid = np.array([5.0, 10.0, 20.0])
    assert f["bend"](grid, 2.0) == pytest.approx(k_bend, rel=0.01)
    assert f["volume"](grid, 2.0) == pytest.approx(k_vol, rel=0.01)
    assert f["bend"](grid, 1.0) == pytest.approx(1 + 0.5 * (k_bend - 1), rel=0.01)  # linear in the intensity
    assert f["bend"](grid, 0.0) == pytest.approx(1.0)
    assert f["length"](grid, 2.0) == pytest.approx(1.0)  # the tip where the nominal's is at that bend


def test_a_response_passes_through_every_run_and_extends_its_last_piece():
    flat = [Factor(np.array([0.0, 10.0]), np.full(2, v)) for v in (0.9, 1.5)]
    r = Response((1.0, 3.0), tuple(flat))
    p = np.array([5.0, 5.0, 5.0, 5.0, 5.0])
    assert r(p, np.array([0.0, 0.5, 1.0, 3.0, 5.0])) == pytest.approx([1.0, 0.95, 0.9, 1.5, 2.1])


def test_solve_stiffened_inverts_p_times_ratio():
    ratio = Factor(np.array([0.0, 50.0]), np.array([1.0, 1.5]))
    p_m = np.array([0.0, 5.0, 20.0, 60.0])
    q = solve_stiffened(p_m, ratio)
    assert q * ratio(q) == pytest.approx(p_m, rel=1e-5)  # tabulated on 1025 points: to 1e-5


def _with_variants(design, k_layer=1.2, k_stiff=1.3):
    """The stored steps plus variants made by scaling their pressure (layer: k x p; stiffer: p / k)."""
    c = characterisation_from_steps(STEPS, design)
    p = c.pressure_kpa
    keys = ("bend_angle_deg", "tip_x_mm", "tip_z_mm", "cavity_volume_ml", "max_principal_stretch")

    def scaled(k):
        return {"pressure_kpa": p.tolist(), **{n: np.interp(p * k, p, getattr(c, n)).tolist() for n in keys}}

    return replace(c, variants={"layer_compliance=0.15": {"value": 0.15, **scaled(k_layer)},
                                "strain_stiffening=0.04": {"value": 0.04, **scaled(1 / k_stiff)}})


def test_the_reduced_model_reproduces_each_variant_at_its_reference_value(fpn):
    rom = ReducedModel(fpn, _with_variants(fpn))
    p = np.linspace(0.0, 0.6 * rom.characterisation.max_pressure_kpa, 9)
    proto = Protocol("bending", p, "none")
    base = rom.run(proto, OFF)
    soft = rom.run(proto, {**OFF, "layer_compliance": 0.15})
    stiff = rom.run(proto, {**OFF, "strain_stiffening": 0.04})
    ref = rom.run(Protocol("bending", p * 1.2, "none"), OFF)
    assert soft["bend_angle_deg"][1:] == pytest.approx(ref["bend_angle_deg"][1:], rel=0.01)
    assert soft["cavity_volume_ml"][1:] == pytest.approx(ref["cavity_volume_ml"][1:], rel=0.01)
    slow = rom.run(Protocol("bending", p / 1.3, "none"), OFF)
    assert stiff["bend_angle_deg"][1:] == pytest.approx(slow["bend_angle_deg"][1:], rel=0.01)
    assert np.all(stiff["bend_angle_deg"][1:] < base["bend_angle_deg"][1:])
    # a smaller value: a smaller share of the same response, in order
    half = rom.run(proto, {**OFF, "layer_compliance": 0.05})
    assert np.all(base["bend_angle_deg"][1:] < half["bend_angle_deg"][1:])
    assert np.all(half["bend_angle_deg"][1:] < soft["bend_angle_deg"][1:])


def test_a_volume_factor_moves_the_volume_and_not_the_shape(fpn):
    c = _with_variants(fpn)
    layer = dict(c.variants["layer_compliance=0.15"])
    layer["bend_angle_deg"] = c.bend_angle_deg.tolist()  # the layer moves the volume only
    rom = ReducedModel(fpn, replace(c, variants={"layer_compliance=0.15": layer}))
    proto = Protocol("bending", np.linspace(0.0, 20.0, 5), "none")
    base, soft = rom.run(proto, OFF), rom.run(proto, {**OFF, "layer_compliance": 0.15})
    assert soft["bend_angle_deg"] == pytest.approx(base["bend_angle_deg"], abs=0.05)
    assert np.all(soft["cavity_volume_ml"][1:] > base["cavity_volume_ml"][1:] + 1e-3)


def test_a_stretch_moves_the_tip_along_the_same_bend(fpn):
    """A variant with the nominal bend and volume whose tip is 1 % further from the clamp's end:
    the free edges stretch 1 %, the clamped part keeps its length, the bend is the same."""
    from pnmold.physics.identify import chamber_bounds_mm

    c = characterisation_from_steps(STEPS, fpn)
    x_clamp = chamber_bounds_mm(fpn)[1]
    names = ("pressure_kpa", "bend_angle_deg", "cavity_volume_ml", "max_principal_stretch")
    longer = {"value": 0.15, **{n: getattr(c, n).tolist() for n in names},
              "tip_x_mm": (x_clamp + 1.01 * (c.tip_x_mm - x_clamp)).tolist(), "tip_z_mm": (1.01 * c.tip_z_mm).tolist()}
    rom = ReducedModel(fpn, replace(c, variants={"layer_compliance=0.15": longer}))
    proto = Protocol("bending", np.array([0.0, 10.0, 20.0]), "none")
    base, soft = rom.run(proto, OFF), rom.run(proto, {**OFF, "layer_compliance": 0.15})
    assert soft["bend_angle_deg"] == pytest.approx(base["bend_angle_deg"], abs=1e-6)
    assert soft["tip_x_mm"][0] == base["tip_x_mm"][0]  # unloaded: nothing to stretch
    assert soft["tip_x_mm"][1:] - x_clamp == pytest.approx(1.01 * (base["tip_x_mm"][1:] - x_clamp), rel=1e-6)
    assert soft["tip_z_mm"][1:] == pytest.approx(1.01 * base["tip_z_mm"][1:], rel=1e-6)
