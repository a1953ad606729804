"""``diagnose``: recordings against the model -> a :class:`Diagnosis` (schema pnmold.diagnosis/1)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pnmold.errors import SolveError
from pnmold.recording import Recording

from . import explain
from .calibrate import (
    baseline_pinned,
    calibration_notes,
    calibration_parameters,
    check_material,
    modulus_pinned,
    other_rubber_fits,
    reach_scale,
)
from .data import MODEL_FORM_SHARE, PRESSURE_FORM_SHARE, DataSet, build_dataset
from .decide import DCHI2_MIN, Candidate, Decision, decide, excess_sigma, ladder_parameter
from .fitting import Fitter, Forward, zscores
from .locate import locate

SCHEMA = "pnmold.diagnosis/1"
#: the share of rows beyond the FE's characterisation above which a diagnosis is refused (assumed)
REFUSE_BEYOND_FE = 0.2
#: the design's floor is read again, once, at the calibrated modulus when that is this factor away from where it
#: was read (assumed: the floor changes little within 10 % of a modulus)
FLOOR_RESCALE = 1.1
UNITS = {"tip_x_mm": "mm", "tip_z_mm": "mm", "volume_ml": "mL", "force_n": "N", "pressure_kpa": "kPa",
         "bend_angle_deg": "deg", "flow_slpm": "SLPM", "pressure_far_kpa": "kPa"}


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """The JSON document (``doc``) and what the plots need."""

    doc: dict[str, Any]
    data: DataSet
    decision: Decision
    seconds: float

    @property
    def named(self) -> list[str]:
        return [m["effect"] for m in self.doc["missing_physics"]]

    @property
    def past_maximum(self) -> bool:
        """Rows lie past the calibrated baseline's pressure maximum."""
        return _past_maximum(self.decision.baseline.fit.predictions, self.data)


def by_series(data: DataSet, z: np.ndarray) -> list[np.ndarray]:
    out, i = [], 0
    for s in data.series:
        out.append(z[i:i + s.y.size])
        i += s.y.size
    return out


def _rmse(data: DataSet, z: np.ndarray, observable: str) -> float:
    """RMSE in the observable's units over every series of that observable."""
    parts = [zs * s.sigma for s, zs in zip(data.series, by_series(data, z), strict=True)
             if s.observable == observable]
    return explain.rmse(np.concatenate(parts)) if parts else float("nan")


def _residuals(data: DataSet, c: Candidate) -> list[np.ndarray]:
    """Per series, measured minus the candidate's prediction (the observable's units)."""
    return [s.y - np.asarray(c.fit.predictions[s.recording][s.observable], float)[s.rows] for s in data.series]


def _full_z(fitter: Fitter, c: Candidate) -> np.ndarray:
    return zscores(fitter.data, c.fit.predictions)


def diagnose(design_entry: dict[str, str], recordings: Sequence[Recording], forward: Forward,
             effects: list, *, seed: int = 0, reach: dict[str, Any] | None = None,
             model_form_share: float = MODEL_FORM_SHARE,
             pressure_form_share: float = PRESSURE_FORM_SHARE, stiffening_top_mpa: float = 0.0,
             design_floor: Callable[[float], list[dict[str, np.ndarray]]] | None = None) -> Diagnosis:
    """Calibrate, locate, rank, fit, accept; ``effects`` are catalogue entries to consider
    (those whose kinds include a recorded kind). ``reach``: how far the model's FE
    characterisation went (``max_pressure_kpa``, ``full_bend_pressure_kpa``, ``reason``), to say
    where the answer rests on extrapolation (and refuse it when most of it does).
    ``model_form_share``: the model's own form error as a share of each observable's range, the
    noise floor of a recording without repeated cycles (:data:`pnmold.diagnose.data.MODEL_FORM_SHARE`), and
    ``pressure_form_share`` its error in pressure, carried through the model's slope on quasi-static
    recordings (:data:`pnmold.diagnose.data.PRESSURE_FORM_SHARE`). ``stiffening_top_mpa`` > 0: the forward's
    model has a stiffening ladder up to that Yeoh C30 (:func:`pnmold.diagnose.model.stiffening_top`), and
    ``strain_stiffening`` is fitted by its C30 on it. ``design_floor(modulus_scale)``: per recording,
    observable -> per row, the standard deviation the design's stated dimensional uncertainty gives
    (:class:`pnmold.physics.uncertainty.DesignFloor`), read at that modulus: a floor under the noise, read
    again, once, at the calibrated modulus when that is over :data:`FLOOR_RESCALE` away."""
    t0 = time.perf_counter()
    kinds = {r.kind for r in recordings}
    effects = [e for e in effects if kinds & set(e.kinds)]
    frame = any(r.kind == "bending" and r.measurement.tip_origin == "camera" for r in recordings)
    scale, check, left_out, floor_at, refloored = 1.0, None, {}, None, False
    # as it is; about the material the recordings need; the design's floor at the calibrated modulus;
    # without the rows out of reach
    for _ in range(4):
        start = {} if scale == 1.0 else {"modulus_scale": scale}
        floor_at = floor_at or scale
        data = build_dataset(list(recordings), _prediction(forward, recordings, start), model_form_share, left_out,
                             pressure_form_share, design_floor(floor_at) if design_floor else None)
        fitter = Fitter(data, forward)
        calibration = calibration_parameters(scale, frame)
        decision = decide(fitter, effects, seed=seed, calibration=calibration,
                          main=ladder_parameter(stiffening_top_mpa))
        pinned = modulus_pinned(decision, calibration)  # not a batch of rubber, and no effect frees it
        past = _past_maximum(decision.final.fit.predictions, data)  # the rubber cannot reach the recordings
        if check is None and (pinned or past or baseline_pinned(decision, calibration)):
            least = reach_scale(_prediction(forward, recordings, {}))
            check = check_material(fitter, frame, design_entry.get("material") or "rubber", least)
            if not check.in_window and (pinned or past or other_rubber_fits(check, decision, DCHI2_MIN)):
                scale, floor_at = check.scale, None
                continue
            if not check.in_window:
                check = None  # an effect explains what another rubber would not: judged in the window
        fitted = decision.baseline.fit.values.get("modulus_scale", scale)
        if design_floor and not refloored and abs(np.log(fitted / floor_at)) > np.log(FLOOR_RESCALE):
            floor_at, refloored = fitted, True  # the recordings read on the design's runs where the fit put them
            continue
        out_of_reach = _out_of_reach(decision.final.fit.predictions, data)
        if not out_of_reach:
            break
        left_out = {i: left_out.get(i, np.zeros(len(recordings[i]), bool)) | m for i, m in out_of_reach.items()}
    base, final = decision.baseline, decision.final
    notes = [*calibration_notes(final, calibration, check), *explain.left_out(recordings, left_out),
             *_extrapolation(final.fit.predictions, data, reach, final.fit.values.get("modulus_scale", 1.0))]
    mismatch = locate(data, by_series(data, _full_z(fitter, base)), residuals=_residuals(data, base))
    observable = mismatch[0]["observable"] if mismatch else data.series[0].observable
    unit = UNITS.get(observable, "")
    fit = {
        "observable": observable,
        "rmse_before": _rmse(data, _full_z(fitter, base), observable),
        "rmse_after": _rmse(data, _full_z(fitter, final), observable),
        "heldout_rmse_before": _rmse(data, base.heldout_z, observable),
        "heldout_rmse_after": _rmse(data, final.heldout_z, observable),
    }
    by_name = {e.name: e for e in effects}
    missing, rig_notes = [], []
    for cand in decision.accepted:
        name = cand.fit.hypothesis.effects[-1]
        effect = by_name[name]
        values, spread = explain.effect_values(final, effect)  # as the final model holds it, with every named effect
        missing.append({
            "effect": name,
            "parameters": values,
            "uncertainty": spread,
            "evidence": {"heldout_chi2_gain": round(cand.gain, 1), "heldout_gain_t": round(cand.t_gain, 2),
                         "excess_removed": round(cand.excess_share, 3), "bootstrap_wins": round(cand.stability, 3),
                         "heldout_chi2_per_point": round(cand.heldout_chi2 / cand.heldout_z.size, 3)},
            "explanation": explain.explanation(effect, values, spread, mismatch, fit["heldout_rmse_before"],
                                               fit["heldout_rmse_after"], unit),
        })
        if name == "dead_volume":
            rig_notes += _check_rig(missing[-1], recordings, final.fit.predictions)
    judged = final.predictive_z if final.predictive_z is not None else final.heldout_z
    excess = excess_sigma(float(np.sum(judged ** 2)), judged.size)  # what the verdict was judged on
    # where the final model still misses (the baseline's misfit is ``mismatch``)
    left = (locate(data, by_series(data, _full_z(fitter, final)), residuals=_residuals(data, final))
            if decision.unexplained else [])
    if decision.unexplained:  # what was named still counts; what is left is said after it
        summary = " ".join([*(m["explanation"] for m in missing),
                            explain.unexplained(fit["heldout_rmse_after"], unit, excess, [e.name for e in effects],
                                                left[0]["description"] if left else None,
                                                left[0]["observable"] if left else None)])
    elif not missing:
        summary = explain.nothing_missing(fit["heldout_rmse_after"], unit, excess)
    else:
        summary = " ".join(m["explanation"] for m in missing)
    summary = " ".join([explain.calibrated(final.fit.values), *notes, summary, *rig_notes])
    doc = {
        "schema": SCHEMA,
        "design": design_entry,
        "recordings": [{"path": r.path, "kind": r.kind, "rows": len(r), "orientation": r.orientation,
                        "conversions": dict(r.conversions)} for r in recordings],
        "baseline": {"calibrated": {k: round(v, 6) for k, v in base.fit.values.items()},
                     "rmse": fit["rmse_before"], "heldout_rmse": fit["heldout_rmse_before"]},
        "calibration": {"final": {k: round(v, 6) for k, v in final.fit.values.items()
                                  if k in {p.key for p in calibration}},
                        "material_check": None if check is None else check.as_json(), "notes": notes},
        "noise": {s.name: s.level for s in data.series},
        "noise_parts": {s.name: {"measurement": s.measurement, "model_form": s.model_form,
                                  "design_uncertainty": s.design} for s in data.series},
        "mismatch": mismatch,
        "remaining_mismatch": left,
        "missing_physics": missing,
        "unexplained": bool(decision.unexplained),
        "fit": {k: (round(v, 6) if isinstance(v, float) else v) for k, v in fit.items()},
        "candidates": [_candidate_entry(c) for c in decision.ranked],
        "summary": summary,
        "alternatives": _alternatives(decision),
        "model_evaluations": fitter.evaluations,
        "seconds": round(time.perf_counter() - t0, 3),
    }
    return Diagnosis(doc, data, decision, time.perf_counter() - t0)


def _check_rig(entry: dict[str, Any], recordings: Sequence[Recording],
               predictions: list[dict[str, np.ndarray]]) -> list[str]:
    """A named dead volume against the air column a volume-driven air rig's own rows allow
    (:func:`explain.air_column_bound`): ``rig_check`` in the entry; the words for the summary."""
    for rec, pred in zip(recordings, predictions, strict=True):
        if "cavity_volume_ml" not in pred:
            continue
        rest = float(np.asarray(pred["cavity_volume_ml"], float)[int(np.argmin(rec.columns["pressure_kpa"]))])
        bound = explain.air_column_bound(rec, rest)
        if bound is None:
            continue
        fits, words = explain.dead_volume_check(entry["parameters"]["dead_volume"],
                                                entry["uncertainty"]["dead_volume"], bound)
        entry["rig_check"] = {"recording": rec.path, "air_bound_ml": round(bound["bound_ml"], 4),
                              "air_bound_as_recorded_ml": round(bound["exact_ml"], 4),
                              "at_pressure_kpa": bound["pressure_kpa"], "consistent": fits, "words": words}
        return [words]
    return []


def _prediction(forward: Forward, recordings: Sequence[Recording], calibration: dict[str, float]
                ) -> list[dict[str, np.ndarray]]:
    """The model's prediction to judge the noise against; where it has none (no equilibrium), the
    data's own curve stands in (the noise then also holds its curvature: an overestimate)."""
    try:
        return forward({}, calibration)
    except SolveError:
        return [{k: np.zeros(len(r)) for k in r.columns} for r in recordings]


def _past_maximum(predictions: list[dict[str, np.ndarray]], data: DataSet) -> bool:
    """Any kept row past the model's pressure maximum (``pressure_excess``): the modulus the window
    allows cannot reach the recordings."""
    return bool(_rows_where(predictions, data, "pressure_excess").any())


def _out_of_reach(predictions: list[dict[str, np.ndarray]], data: DataSet) -> dict[int, np.ndarray]:
    """Recording index -> the kept rows where the model has no equilibrium (NaN: past its limit point;
    rows past the FE's pressure maximum are not NaN but scored, see :func:`.fitting.zscores`)."""
    out: dict[int, np.ndarray] = {}
    for s in data.series:
        f = np.asarray(predictions[s.recording][s.observable], float)
        bad = np.zeros(f.size, bool)
        bad[s.rows] = ~np.isfinite(f[s.rows])
        if bad.any():
            out[s.recording] = out.get(s.recording, np.zeros(f.size, bool)) | bad
    return out


def _rows_where(predictions: list[dict[str, np.ndarray]], data: DataSet, key: str) -> np.ndarray:
    """Per kept row of every recording (once, whatever its observables), the prediction's flag ``key``."""
    kept = {s.recording: s.rows for s in data.series}
    return np.concatenate([np.asarray(predictions[i].get(key, np.zeros(len(data.recordings[i]))), float)[rows] > 0
                           for i, rows in kept.items()])


def _extrapolation(predictions: list[dict[str, np.ndarray]], data: DataSet, reach: dict[str, Any] | None,
                   scale: float = 1.0) -> list[str]:
    """Where the final model reads its FE law beyond the pressures the FE solved: said, and refused
    (SolveError) when that is most of the data and the FE stopped short of full bend. Rows past the
    FE's pressure maximum are not read off any law (the model has no equilibrium there): said, with
    how they were judged. ``scale``: the calibrated modulus scale, by which the FE's pressures carry
    over to the recordings'."""
    past = _rows_where(predictions, data, "pressure_excess")
    full = _rows_where(predictions, data, "volume_excess")  # read by volume: more than the model can take
    beyond = int(np.sum(_rows_where(predictions, data, "beyond_fe") & ~past & ~full))
    total = past.size
    if reach is None or not (beyond or past.any() or full.any()):
        return []
    top = reach["max_pressure_kpa"]
    where = (f"{top:.4g} kPa" if abs(scale - 1.0) < 1e-6 else
             f"{top * scale:.4g} kPa of the recordings ({top:.4g} kPa with the design's rubber, times the "
             f"calibrated modulus scale {scale:.3g})")
    notes = []
    if past.any():
        share = data.series[0].pressure_share or PRESSURE_FORM_SHARE
        notes.append(f"{int(past.sum())} of {total} rows lie past the model's pressure maximum ({where}; "
                     f"{reach.get('reason') or 'the FE'}): it has no equilibrium there under pressure control, so "
                     f"each counts by the share of its pressure the model cannot hold ({100 * share:.3g} % of the "
                     f"pressure is one standard deviation). A volume-driven rig follows the actuator past such a "
                     f"maximum; the model does not.")
    if full.any():
        share = data.series[0].pressure_share or PRESSURE_FORM_SHARE
        notes.append(f"{int(full.sum())} of {total} rows read by the volume their rig set hold more than the model "
                     f"takes up to its pressure maximum ({where}; {reach.get('reason') or 'the FE'}): each counts by "
                     f"the share of its volume the model cannot take ({100 * share:.3g} % of the volume is one "
                     f"standard deviation).")
    if not beyond:
        return notes
    short = reach.get("full_bend_pressure_kpa") is None and reach.get("reason")
    if short and beyond > REFUSE_BEYOND_FE * total:
        raise SolveError(f"{beyond} of {total} rows need the model beyond {where}, where the FE's "
                         f"characterisation of the design stopped ({reach['reason']}): the answer would rest on "
                         f"extrapolation. Check the design (the FE must reach the recordings' bend) before diagnosing.")
    return [*notes, f"{beyond} of {total} rows lie beyond the pressure the FE characterised ({where}"
            + (f", where its solve stopped: {reach['reason']}" if short else ", past full bend") + "): the model "
            "extrapolates its law there."]


def _candidate_entry(c: Candidate) -> dict[str, Any]:
    return {"effect": c.label, "heldout_chi2_per_point": round(c.heldout_chi2 / c.heldout_z.size, 4),
            "heldout_chi2_gain": round(c.gain, 1), "heldout_gain_t": round(c.t_gain, 2),
            "excess_removed": round(c.excess_share, 3),
            "bootstrap_wins": round(c.stability, 3), "plausible": c.plausible,
            "parameters": {k: float(f"{v:.6g}") for k, v in c.fit.values.items()}, "notes": c.notes}


def _alternatives(decision: Decision) -> list[dict[str, str]]:
    """When the runner-up fits nearly as well, the experiment that would separate them."""
    if not decision.accepted or len(decision.ranked) < 2:
        return []
    best, second = decision.ranked[0], decision.ranked[1]
    if second.heldout_chi2 > best.heldout_chi2 + 4.0 * np.sqrt(2.0 * best.heldout_z.size):
        return []
    name = second.fit.hypothesis.effects[0]
    return [{"effect": name, "experiment": explain.SEPARATING_EXPERIMENT.get(name, ""),
             "why": f"{name} fits the held-out data nearly as well ({second.heldout_chi2:.0f} vs "
                    f"{best.heldout_chi2:.0f} chi-square)"}]
