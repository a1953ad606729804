"""Plain words: what was left out, what in the data shows it, and how much the fit improved."""

from __future__ import annotations

import numpy as np

from pnmold.physics.reading import P_ATM_KPA

#: the experiment that separates an effect from the ones it is confused with (docs/diagnosis.md)
SEPARATING_EXPERIMENT = {
    "gravity": "repeat the ramp with the actuator flipped (chambers down) or submerged in water",
    "strain_stiffening": "ramp to a higher pressure, or fit the rubber to a tensile test to large strain",
    "self_contact": "record the blocked force, or photograph the chamber walls near full bend",
    "layer_compliance": "measure the bottom face's length at full bend (tip x beyond the arc length)",
    "mullins": "cycle the actuator three times: the first loading differs, later ones repeat",
    "viscoelasticity": "repeat the cycle at a tenfold slower or faster ramp rate",
    "dead_volume": "record a pressure-volume curve with the tubing shortened",
    "flow_restriction": "repeat the step with a shorter or wider supply tube",
}


def _digits(v: float) -> float:
    """Six significant digits (a Yeoh C30 of 1e-5 MPa keeps its own)."""
    return float(f"{float(v):.6g}")


def effect_values(cand, effect) -> tuple[dict[str, float], dict[str, float | None]]:
    """The fitted parameters of ``effect`` in ``cand`` and their fold spread (None where the recordings hold
    too few rows for two held-out folds: no spread to measure)."""
    unc = cand.uncertainty()
    values, spread = {}, {}
    for key, v in cand.fit.values.items():
        if key == effect.name or key.startswith(effect.name + "."):
            values[key] = _digits(v)
            spread[key] = _digits(unc[key]) if np.isfinite(unc[key]) else None
    return values, spread


def main_parameter(effect, values: dict[str, float]) -> tuple[str, str]:
    """The parameter an effect's explanation names, of its fitted ``values``: its key and unit (the
    effect's own parameter, or the one fitted instead)."""
    key = effect.name if effect.name in values else next(iter(values))  # or the parameter fitted instead
    unit_of = effect.unit if key == effect.name else next(x[1] for x in effect.extra if key.endswith("." + x[0]))
    return key, unit_of


#: what to check when the data show an effect the rig declares on at another value than declared
DECLARED_CHECK = {"gravity": "check how the actuator was held: a tip resting on a support or a table, a hand or "
                             "tubing carrying its weight, or another orientation than the recording's metadata says"}


def explanation(effect, values: dict[str, float], spread: dict[str, float], mismatch: list[dict],
                rmse_before: float, rmse_after: float, unit: str, at_bound: bool = False) -> str:
    key, unit_of = main_parameter(effect, values)
    main = values[key]
    where = mismatch[0]["description"] if mismatch else "a small, spread-out misfit"
    what = effect.description[0].lower() + effect.description[1:].rstrip(".")
    if getattr(effect, "default", 0.0) != 0.0:  # declared on by the rig: the data show it at another value
        opening = (f"The data show {what} other than the rig declares ({effect.name}: {main:.3g} {unit_of} against "
                   f"the declared {effect.default:g} {unit_of}); {DECLARED_CHECK.get(effect.name, 'check the rig')}.")
    else:
        opening = f"The model left out {what} ({effect.name})."
    bound = (f", the catalogue's upper bound: the data want at least that much (a stronger {effect.name} than "
             f"the catalogue assumes plausible, or a model that carries it weaker than the actuator does)"
             if at_bound else f" (+- {spread[key]:.2g})" if spread[key] is not None else
             " (its spread not measured: too few rows for two held-out folds)")
    unit_words = "" if unit_of in ("", "1") else f" {unit_of}"  # a ratio has no unit to say
    return (f"{opening} What shows it: {where}; this is its fingerprint: "
            f"{effect.fingerprint[0].lower() + effect.fingerprint[1:].rstrip('.')}. "
            f"With {key} = {main:.3g}{unit_words}{bound}, the held-out "
            f"error fell from {rmse_before:.3g} to {rmse_after:.3g} {unit}.")


#: rows of a P-V recording above this share of its top pressure bound its air column (below it, the
#: pressure's reading error is too large a share of the pressure; assumed)
AIR_BOUND_SHARE = 0.1


def air_column_bound(recording, cavity_rest_ml: float) -> dict[str, float] | None:
    """The most air (mL, besides the cavity's own and the stated column) a volume-driven air rig can
    hold, from its recording alone: at every row the piston's stroke v went into the cavity (a change
    >= 0) and into compressing the air, so Boyle's law gives V_air <= v (p_atm + p) / p; the
    smallest over the rows above :data:`AIR_BOUND_SHARE` of the top pressure. With the rig's stated
    accuracies (metadata) the rows are read at their most generous (v + dv, p - dp): ``bound_ml`` is
    then that, ``exact_ml`` the bound of the readings as recorded. None for other rigs."""
    m = recording.measurement
    if recording.kind != "pv" or m.rig != "volume" or m.medium != "air":
        return None
    p = np.asarray(recording.columns["pressure_kpa"], float)
    v = np.asarray(recording.columns["volume_ml"], float)
    rows = np.flatnonzero((p > 0) & (p >= AIR_BOUND_SHARE * p.max()))
    if rows.size == 0:
        return None
    exact = v[rows] * (P_ATM_KPA + p[rows]) / p[rows]
    low = p[rows] - m.pressure_accuracy_kpa
    widest = np.where(low > 0, (v[rows] + m.volume_accuracy_ml) * (P_ATM_KPA + low) / np.maximum(low, 1e-300),
                      np.inf)
    i = int(np.argmin(widest))
    less = cavity_rest_ml + m.air_column_ml
    return {"bound_ml": float(widest[i]) - less, "exact_ml": float(exact.min()) - less,
            "pressure_kpa": float(p[rows][i]), "stroke_ml": float(v[rows][i]), "cavity_rest_ml": cavity_rest_ml,
            "pressure_accuracy_kpa": m.pressure_accuracy_kpa, "volume_accuracy_ml": m.volume_accuracy_ml}


def dead_volume_check(value_ml: float, spread_ml: float, bound: dict[str, float]) -> tuple[bool, str]:
    """Whether a named dead volume fits under the recording's own bound, and the words saying so."""
    fits = value_ml - spread_ml <= bound["bound_ml"]
    within = ""
    if bound["pressure_accuracy_kpa"] or bound["volume_accuracy_ml"]:
        within = (f" within the rig's stated accuracy (+-{bound['pressure_accuracy_kpa']:.3g} kPa, "
                  f"+-{bound['volume_accuracy_ml']:.3g} mL; {bound['exact_ml']:.3g} mL as recorded)")
    how = (f"the recording's own rows allow at most {bound['bound_ml']:.3g} mL of air{within} (Boyle's law at "
           f"{bound['pressure_kpa']:.3g} kPa: all of the piston's {bound['stroke_ml']:.3g} mL into air, less the "
           f"cavity's own {bound['cavity_rest_ml']:.3g} mL)")
    if fits:
        return True, f"Checked against the rig: {how}; {value_ml:.3g} mL is within it."
    return False, (f"Checked against the rig: {how}; {value_ml:.3g} mL is more, so it is too large: the model's "
                   f"cavity takes too little of the stroke where the pressure is high and the air column makes up "
                   f"for it. Check the design's chambers (their size and how much their walls balloon).")


def declared(recordings) -> str:
    """The rig as the recordings declare it, the diagnosis's starting model, in words."""
    parts = []
    for r in recordings:
        m = r.measurement
        said = [f"{r.orientation} ({_weight(r.orientation)})"] if r.kind != "step" else ["a supply step"]
        if r.kind == "bending":
            said.append({"clamp": "the tip measured from the clamp", "rest": "the tip measured from its rest",
                         "camera": "the tip in a camera's frame"}[m.tip_origin])
            if m.bending_length_mm is not None:
                said.append(f"the bend angle over {m.bending_length_mm:g} mm")
        if r.kind == "pv":
            said.append(f"{m.medium} driven by {'a piston' if m.rig == 'volume' else 'a regulator'}, "
                        f"{m.air_column_ml:g} mL of air stated")
        parts.append(f"{r.kind} {', '.join(said)}")
    return ("The starting model is the rig as the recordings declare it: " + "; ".join(parts) + ". An effect is "
            "named only where the data differ from that.")


def _weight(orientation: str) -> str:
    return {"chambers_up": "its weight along -z", "chambers_down": "its weight along +z",
            "horizontal": "its weight across the bending plane, rolling the body about its length",
            "submerged": "its weight less the water's buoyancy"}.get(orientation, "no weight")


def calibrated(values: dict[str, float]) -> str:
    """The calibrated nominal values, in words (always shown: the answer rests on them)."""
    parts = [f"the rubber's modulus x {values['modulus_scale']:.3g} of the design's"]
    if "density_scale" in values:
        parts.append(f"its density x {values['density_scale']:.3g}")
    if "frame_dx_mm" in values:
        parts.append(f"the camera frame offset ({values['frame_dx_mm']:.3g}, {values['frame_dz_mm']:.3g}) mm and "
                     f"turned {values['frame_rotation_deg']:.3g} deg")
    return "Calibrated: " + "; ".join(parts) + "."


def left_out(recordings, masks: dict) -> list[str]:
    """Plain words on the rows left out because the model has no equilibrium there."""
    out = []
    for i, mask in sorted(masks.items()):
        rec = recordings[i]
        p = np.asarray(rec.columns["pressure_kpa"], float)[mask]
        why = ("the blocked tip slides off the frictionless plane" if rec.kind == "force"
               else "past the model's limit point")
        out.append(f"The model has no equilibrium for {int(mask.sum())} row(s) of {rec.path} ({rec.kind}, "
                   f"{p.min():.4g}-{p.max():.4g} kPa: {why}); they are left out of the comparison.")
    return out


def nothing_missing(rmse: float, unit: str, excess: float) -> str:
    return (f"Nothing significant is missing: after recalibrating the modulus, the model's held-out "
            f"error ({rmse:.3g} {unit}) is what the noise in the recordings allows "
            f"(excess misfit {excess:.1f} standard deviations).")


#: observable -> what of the rig to check when structure remains there: the model's own rig, in words
RIG_CHECKS = {"force_n": "the blocked-force rig as the model has it: a rigid frictionless plane under the tip at its "
                         "rest height; check where the plate meets the actuator (the tip, or along its side), that the "
                         "plate and the load cell do not give, and that nothing else holds the actuator"}


def unexplained(rmse: float, unit: str, excess: float, tried: list[str], where: str | None = None,
                observable: str | None = None) -> str:
    """``where``: the strongest window the final model still misses (a ``remaining_mismatch`` entry's words),
    in ``observable`` (its rig's check is said: :data:`RIG_CHECKS`)."""
    rig = RIG_CHECKS.get(observable or "")
    return (f"Structure remains that no catalogued effect explains: the held-out error is still {rmse:.3g} "
            f"{unit}, {excess:.1f} standard deviations beyond the noise after trying "
            f"{', '.join(tried)}" + (f"; the final model still misses here: {where}" if where else "") +
            ". Look for a cause outside the catalogue: a design that is not the "
            "actuator as built (a wall, layer or side it leaves out, sizes read off a drawing: compare "
            "the part with design.toml), a leak, a torn wall, a mislabelled column"
            + (f"; and {rig}." if rig else "."))


def rmse(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values ** 2))) if values.size else float("nan")
