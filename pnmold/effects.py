"""The catalogue of physics effects (docs/effects.md): one composable term each, in one place.

Every effect has one physical parameter whose value 0 switches it off (``gravity`` = 1 is
Earth's gravity), bounds that are physically plausible, the recording kinds that show it,
the fingerprint it leaves in data, and where it is modelled: the reduced model (``rom``),
the FE (``fe``) or the pneumatic step model (``dynamic``). Further parameters of an effect
are given as ``NAME.PARAM=VALUE`` (``extra``). ``default`` is the value a simulation uses
when the effect is not named: gravity is on (1 g), every other term off.

A leaf module (it imports nothing of pnmold but the errors): the models read the catalogue,
the catalogue knows no model. Adding an effect is one more ``Effect(...)`` in
:data:`CATALOGUE`; :func:`check_effects` is the one validator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from pnmold.errors import DesignError

Extra = tuple[str, str, float, tuple[float, float]]  # (parameter, unit, default, bounds)


@dataclass(frozen=True)
class Effect:
    """One catalogued term. ``models``: where it is modelled (``rom``, ``fe``, ``dynamic``)."""

    name: str
    parameter: str
    unit: str
    default: float
    bounds: tuple[float, float]
    kinds: tuple[str, ...]
    description: str
    fingerprint: str
    extra: tuple[Extra, ...] = ()
    rom: str = ""
    fe: str = ""
    source: str = "assumed"
    models: tuple[str, ...] = ("rom",)

    def as_json(self) -> dict:
        return {"name": self.name, "parameter": self.parameter, "unit": self.unit, "default": self.default,
                "bounds": list(self.bounds), "kinds": list(self.kinds), "description": self.description,
                "fingerprint": self.fingerprint,
                "extra": [{"parameter": p, "unit": u, "default": d, "bounds": list(b)} for p, u, d, b in self.extra],
                "rom": self.rom, "fe": self.fe or None, "source": self.source, "models": list(self.models)}


SI = "Mosadegh et al. 2014, Supporting Information"

CATALOGUE: tuple[Effect, ...] = (
    Effect(
        "gravity", "g", "g", 1.0, (0.0, 2.0), ("bending", "pv", "force"),
        "self-weight of the actuator (and buoyancy when submerged)",
        "tip offset at 0 kPa, largest at low pressure and at the free end; chambers_up bends further "
        "(toward -z) at low pressure and resists curling past 180 deg, chambers_down the opposite; "
        "horizontal: the body rolls about its length under its weight, chambers toward the ground, and sags "
        "toward +z by the share the roll brings into the plane (a soft or tall body most); about a tenth when "
        "submerged "
        "(buoyancy); pv: slightly more "
        "volume at the same pressure when it helps the bend; force: the weight adds to the blocked force",
        rom="distributed weight rho g A(x) at each section's centroid (design layout), net of buoyancy "
            "(1 - rho_water/rho) submerged; bends the rod through the FE-identified hinge compliance; "
            "horizontal: each hinge rolls by the twist before it (compliance from the FE's roll probe) and feels "
            "sin(roll) of the chambers-down moment",
        fe="gravity vector value x g along the orientation (-z chambers_up, +z chambers_down, -y horizontal: the "
           "whole body, which may roll about its length)",
        source=SI + ": 'Gravitational forces were taken into account'; g = 9.80665 m/s^2",
        models=("rom", "fe")),
    Effect(
        "strain_stiffening", "c20_mpa", "MPa", 0.0, (0.0, 0.1), ("bending", "pv", "force"),
        "higher-order hyperelastic stiffening the baseline material lacks (added Yeoh C20/C30)",
        "agreement at low pressure, growing shortfall of bend (and volume) at high pressure: the model "
        "is too soft near full bend",
        extra=(("c30_mpa", "MPa", 0.0, (0.0, 0.02)),),
        rom="the pressure needed for a deformation rises by a factor read from the FE's own free run with "
            "C20 + 0.04 MPa (the characterisation's variant), separately for the bend and the volume, scaled "
            "by the added Yeoh slope dC20 + 1.5 dC30 I1 at the representative stretch (equibiaxial, 1 + 0.12 "
            "x the FE's peak strain); the hinge compliance is divided by the bend's factor. Without the FE "
            "variant: the ratio of the Yeoh slopes dW/dI1 there. A design whose free run ends at a pressure "
            "maximum, with recordings past it: C30 read off the FE's own runs with C30 + 0.001, 0.0025 and 0.006 "
            "x C10 (the stiffening ladder, which goes on past that maximum), interpolated at the same share of "
            "each run's final bend; the diagnosis then fits strain stiffening by its C30",
        fe="material.c20_mpa += value, material.c30_mpa += c30_mpa",
        source="bounds: Yeoh C20 of silicone fits 0-0.02 MPa (" + SI + ": Elastosil C20 = 0.02 MPa; "
               "pnmold library fits); up to 5x that assumed",
        models=("rom", "fe")),
    Effect(
        "self_contact", "share", "1", 0.0, (0.0, 1.5), ("bending", "pv", "force"),
        "neighbouring chamber walls touching at large bend",
        "once the inside walls' bulges meet across the gaps they push the chambers apart: in the FE the fPN "
        "then bends further at the same pressure (+2.6, +12.7, +24.6 deg at 10.2, 20.3, 30.5 kPa on the build's "
        "mesh, benchmarks/contact.py) and its tip meets its base sooner; nothing below the pressure where the "
        "walls first touch",
        rom="the shape and the volume read the free law at the pressure where the nominal reaches the bend (and "
            "the volume) of the FE's own free run with its self-contact on (the characterisation's variant, "
            "pnmold.physics.characterise.self_contact_run), value of the way (1: the FE's contact as solved; "
            "below 1 a contact that sets in later or pushes less, e.g. wider or stiffer gaps than designed); past "
            "that run's end (its tip meets the base) out of reach; the hinges' compliance under the weight moved "
            "value of the way to the one the FE's probes with self-contact identify, chambers up and hanging "
            "chambers down (a weight that closes the gaps presses their walls together; without those probes, as "
            "without contact)",
        fe="SolveOptions(self_contact=SelfContact()): a frictionless penalty contact of the outer surface with "
           "itself (pnmold.fem.contact); pnmold build --self-contact, pnmold simulate --model fe --self-contact",
        source="the FE's own self-contact run; bounds assumed (0: no contact, 1.5: half again the FE's push)",
    ),
    Effect(
        "layer_compliance", "compliance_mm_per_n", "mm/N", 0.0, (0.0, 1.0), ("bending", "pv", "force"),
        "the strain-limiting layer stretches (finite effective E*t): added compliance 1/(E t) per unit width",
        "the bend and the volume part ways: in the FE the fPN bends more at the same pressure (+10 %/+6 % "
        "at 5/23 kPa for 0.3 mm/N) with its volume nearly unchanged, the sPN bends less and takes more "
        "volume (it lengthens instead), most at low pressure: a pressure-dependent change a modulus "
        "change (which moves bend and volume together) does not make",
        rom="the bend and the volume each read the free law at p_eff x a factor from the FE's own free runs "
            "with 0.05 and 0.15 mm/N (the characterisation's variants), piecewise linear in the share of "
            "the bottom's stretching stiffness lost, A = k_r/(k_p + k_r) - (same at value 0) (k_p = 1/(1/(E t) "
            "+ value) the paper's, k_r = 6 C10 x bottom layer the rubber's); the hinge compliance under the weight is "
            "the FE's probe with the layer at 0.15 mm/N, in proportion to A (without that probe: it grows by the "
            "bend's factor). Without the FE variants: the bend's factor 1 + A x 0.75/(1 + e/0.2), e the FE's "
            "peak strain, the volume's 1",
        fe="paper.modulus_mpa = 1 / (t (1/(E t) + value)): the membrane's E*t in series with the added compliance",
        source="bounds: 0 = the paper (E t = 650 N/mm, " + SI + "); 1 mm/N ~ no paper (2 mm of rubber, "
               "E t ~ 1.3 N/mm); response from the FE variants (tests/test_rom.py checks it at other values)",
        models=("rom", "fe")),
    Effect(
        "mullins", "fraction", "1", 0.0, (0.0, 0.5), ("bending", "pv", "force"),
        "first-cycle stress softening: the first loading differs from later ones",
        "the first inflation needs (1 + value) times the pressure for the same bend; every later branch "
        "(deflations, re-inflations to the same peak) repeats the softened curve, which meets the first "
        "loading at the peak; loading past the previous peak is a first loading again",
        extra=(("exponent", "1", 2.0, (1.0, 4.0)),),
        rom="stiffness factor 1 + value on first loading (pressure above the running maximum), "
            "1 + value (p / p_max)^exponent below it (Ogden-Roxburgh-like, pressure as the damage measure)",
        source="assumed (silicone rubbers soften by 5-30 % after the first stretch)",
    ),
    Effect(
        "viscoelasticity", "fraction", "1", 0.0, (0.0, 0.6), ("bending", "pv", "force"),
        "rate-dependent hysteresis between inflation and deflation (one Prony term)",
        "inflate and deflate branches differ (less bend inflating, more deflating), the loop widens with "
        "the rate; creep toward the quasi-static state at a hold; nothing without time_s or a rate",
        extra=(("tau_s", "s", 2.0, (0.05, 100.0)),),
        rom="standard linear solid on the pressure: p = x + h, dh/dt = g/(1-g) dx/dt - h/tau, the free "
            "law is evaluated at x (the FE is the relaxed, long-term response); time from time_s or the rate",
        source="assumed (silicone elastomers: Prony fractions 0.1-0.4, times 0.1-10 s)",
    ),

    Effect(
        "dead_volume", "volume_ml", "mL", 0.0, (0.0, 500.0), ("step", "pv"),
        "compressible gas volume in tubing/fittings in series with the chambers",
        "step: slower pressure rise and bend, same final pressure and bend; metered gas against "
        "inlet pressure offset by V_d (p / p_std) (T_std / T) std mL, growing with pressure; "
        "pv: more volume than the chambers take, V_d p / (p_atm + p) (a trapped bubble in water, or the air "
        "a piston compresses before the actuator), growing with pressure and bending over toward p_atm",
        rom="pv: the recorded volume gains V_d p / (p_atm + p) (isothermal gas between the rig and the cavity; "
            "with an air rig, besides the cavity's own air and the recording's air_column_ml: "
            "pnmold.physics.reading)",
        source="assumed (fittings and sensor tees: 0-20 mL; a piston rig's air column: hundreds of mL)",
        models=("dynamic", "rom")),
    Effect(
        "flow_restriction", "extra_resistance", "1", 0.0, (0.0, 20.0), ("step",),
        "pneumatic resistance of valve, tubing and the connecting channel (multiple of nominal)",
        "step: pressure and flow traces stretched in time by (1 + k), peak flow divided by (1 + k); "
        "final state and the gas-pressure (P-V) relation unchanged; near chambers lead far ones "
        "for longer; response depends on the rate of the input",
        source="assumed (a partly blocked channel, a kinked or longer tube: up to 20x)",
        models=("dynamic",)),
)


EFFECTS: dict[str, Effect] = {e.name: e for e in CATALOGUE}


def catalogue_json() -> list[dict]:
    """``pnmold effects --json``: every effect with name, parameter, unit, default, bounds, kinds, ..."""
    return [e.as_json() for e in EFFECTS.values()]


def check_effects(effects: Mapping[str, float], model: str | None = None) -> dict[str, float]:
    """Validated values by key (``NAME`` or ``NAME.PARAM``); DesignError names the effect.

    ``model`` (``rom``, ``fe``): refuse effects that model does not carry."""
    out = {}
    for key, value in effects.items():
        name, _, param = key.partition(".")
        effect = EFFECTS.get(name)
        if effect is None:
            raise DesignError(f"effects.{name}", f"unknown effect; the catalogue has {', '.join(EFFECTS)}")
        if param:
            extra = {p: (u, b) for p, u, _, b in effect.extra}
            if param not in extra:
                known = ", ".join(f"{name}.{p}" for p in extra) or "none"
                raise DesignError(f"effects.{key}", f"unknown parameter of {name} (parameters: {known})")
            unit, (lo, hi) = extra[param]
        else:
            unit, (lo, hi) = effect.unit, effect.bounds
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise DesignError(f"effects.{key}", f"needs a number, got {value!r}") from None
        if not (math.isfinite(v) and lo <= v <= hi):
            raise DesignError(f"effects.{key}", f"{v:g} is outside the plausible bounds [{lo:g}, {hi:g}] {unit}")
        if model is not None and model not in effect.models:
            raise DesignError(f"effects.{name}", f"not in the {model.upper()} model (it is in: "
                              f"{', '.join(effect.models)})")
        out[key] = v
    return out


def value_of(effects: Mapping[str, float], key: str) -> float:
    """An effect's (or ``NAME.PARAM``'s) value, or its catalogue default."""
    if key in effects:
        return float(effects[key])
    name, _, param = key.partition(".")
    effect = EFFECTS[name]
    if not param:
        return effect.default
    return next(d for p, _, d, _ in effect.extra if p == param)
