"""``diagnose``: recordings against the model -> a :class:`Diagnosis` (schema pnmold.diagnosis/1).

The method is ``docs/diagnosis.md``'s; the document is written by :mod:`pnmold.diagnose.document`
(``docs/json-schemas.md``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

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
    weighs_in_plane,
)
from .data import DataSet, build_dataset
from .decide import DCHI2_MIN, Candidate, Decision, decide, excess_sigma, ladder_parameter
from .document import SCHEMA, Calibrated, Findings, diagnosis_document
from .fitting import Fitter, Forward, zscores
from .inputs import DesignRef, DiagnosisModel
from .locate import locate
from .reach import REFUSE_BEYOND_FE, extrapolation, out_of_reach, past_maximum
from .rest import frame_notes

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["FLOOR_RESCALE", "REFUSE_BEYOND_FE", "SCHEMA", "UNITS", "Diagnosis", "diagnose"]

#: the design's floor is read again, once, at the calibrated modulus when that is this factor away from where it
#: was read (assumed: the floor changes little within 10 % of a modulus)
FLOOR_RESCALE = 1.1
UNITS = {"tip_x_mm": "mm", "tip_z_mm": "mm", "volume_ml": "mL", "force_n": "N", "pressure_kpa": "kPa",
         "bend_angle_deg": "deg", "flow_slpm": "SLPM", "pressure_far_kpa": "kPa"}


@dataclass(frozen=True, eq=False, repr=False)
class Diagnosis:
    """The JSON document (``doc``) and what the plots need.

    Parameters
    ----------
    doc : dict
        The document, schema ``pnmold.diagnosis/1`` (``docs/json-schemas.md``).
    data : DataSet
        The recordings' rows as judged, with their noise.
    decision : Decision
        The baseline, the ranked candidates and the final model.
    seconds : float
        The wall time the diagnosis took.
    effects : tuple
        The catalogue entries considered (for their parameters' units).
    """

    doc: dict[str, Any]
    data: DataSet
    decision: Decision
    seconds: float
    effects: tuple = ()

    @property
    def named(self) -> list[str]:
        return [m["effect"] for m in self.doc["missing_physics"]]

    @property
    def past_maximum(self) -> bool:
        """Rows lie past the calibrated baseline's pressure maximum."""
        return past_maximum(self.decision.baseline.fit.predictions, self.data)

    def figure(self, *, ax: Any = None) -> Figure:
        """The diagnosis's figure (data, baseline and final model, residuals with the located window), as
        :func:`pnmold.diagnose.plots.fit_figure` draws it for the report; no file is written.

        Parameters
        ----------
        ax : a 2 x (number of series) grid of axes to draw on; default a new figure.
        """
        from .plots import fit_figure

        return fit_figure(self, ax=ax)

    def _overview(self) -> dict[str, str]:
        """Design, recordings, named effects, unexplained, held-out RMSE: as words."""
        doc, fit = self.doc, self.doc["fit"]
        kinds: dict[str, list[int]] = {}
        for r in doc["recordings"]:
            kinds.setdefault(r["kind"], []).append(r["rows"])
        recordings = ", ".join(f"{len(rows)} {kind} ({sum(rows)} rows)" if len(rows) > 1 else
                               f"{kind} ({rows[0]} rows)" for kind, rows in kinds.items())
        by_name = {e.name: e for e in self.effects}
        named = ", ".join(_main_parameter(m, by_name.get(m["effect"])) for m in doc["missing_physics"])
        observable = fit["observable"]
        unit = UNITS.get(observable, "")
        return {"design": str(doc["design"]["name"]), "recordings": recordings or "none", "named": named or "nothing",
                "unexplained": "yes" if doc["unexplained"] else "no",
                "held-out RMSE": f"{fit['heldout_rmse_before']:.3g} -> {fit['heldout_rmse_after']:.3g}"
                                 f"{' ' + unit if unit else ''} ({observable})"}

    def __repr__(self) -> str:
        s = self._overview()
        return (f"<Diagnosis {s['design']}: {s['recordings']}; named {s['named']}; unexplained {s['unexplained']};\n"
                f" held-out RMSE {s['held-out RMSE']}>")

    def _repr_html_(self) -> str:
        """The overview as a small table and the summary (Jupyter shows it for a diagnosis)."""
        from html import escape

        from pnmold.frames import summary_html

        return summary_html("pnmold diagnosis", self._overview()) + f"<p>{escape(str(self.doc['summary']))}</p>"


def _main_parameter(entry: dict[str, Any], effect: Any) -> str:
    """A ``missing_physics`` entry by its main parameter, as the explanation names it (``effect``: its
    catalogue entry, for the unit; None: no unit)."""
    name, values = entry["effect"], entry["parameters"]
    if not values:
        return str(name)
    if effect is not None:
        key, unit = explain.main_parameter(effect, values)
    else:
        key, unit = (name if name in values else next(iter(values))), ""
    value = f"{values[key]:.3g}" + ("" if unit in ("", "1") else f" {unit}")
    return f"{key} = {value}" if key == name else f"{name} ({key} = {value})"


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


def diagnose(design: DesignRef, recordings: Sequence[Recording], model: DiagnosisModel) -> Diagnosis:
    """Calibrate, locate, rank, fit, accept (``docs/diagnosis.md``).

    Parameters
    ----------
    design : DesignRef
        The design the recordings are of, as the document names it; its ``material`` is the
        rubber the material check names.
    recordings : sequence of Recording
        The recordings, read and checked.
    model : DiagnosisModel
        The forward model, the catalogue entries to consider (those whose kinds include a recorded
        kind), how far its FE characterisation went (``reach``: where the answer rests on
        extrapolation, and refused when most of it does) and the settings of the judging.

    Returns
    -------
    Diagnosis
        Its ``doc`` the ``pnmold.diagnosis/1`` document.
    """
    t0 = time.perf_counter()
    kinds = {r.kind for r in recordings}
    effects = [e for e in model.effects if kinds & set(e.kinds)]
    cal = _calibrate(design, recordings, model, effects)
    final = cal.decision.final
    notes = [*calibration_notes(final, cal.calibration, cal.check), *frame_notes(recordings, cal.data, final),
             *explain.left_out(recordings, cal.left_out),
             *extrapolation(final.fit.predictions, cal.data, model.reach, final.fit.values.get("modulus_scale", 1.0))]
    mismatch, fit = _fit_summary(cal)
    unit = UNITS.get(fit["observable"], "")
    missing, rig_notes = _named_effects(cal, effects, recordings, mismatch, fit, unit)
    left, summary = _summary(cal, effects, fit, unit, missing)
    summary = " ".join([explain.declared(recordings), explain.calibrated(final.fit.values), *notes, summary,
                        *rig_notes])
    found = Findings(notes, mismatch, fit, missing, left, summary)
    doc = diagnosis_document(design, recordings, cal, found, time.perf_counter() - t0)
    return Diagnosis(doc, cal.data, cal.decision, time.perf_counter() - t0, tuple(effects))


def _calibrate(design: DesignRef, recordings: Sequence[Recording], model: DiagnosisModel, effects: list
               ) -> Calibrated:
    """The search, repeated until it stands: as it is; about the material the recordings need (checked
    once, when the modulus is pinned, the rows past the model's maximum or the baseline pinned); the
    design's floor at the calibrated modulus (once, when that is over :data:`FLOOR_RESCALE` away);
    without the rows out of reach. At most four rounds."""
    forward, design_floor = model.forward, model.design_floor
    frame = any(r.kind == "bending" and r.measurement.tip_origin == "camera" for r in recordings)
    density = weighs_in_plane(recordings)
    scale, check, left_out, floor_at, refloored = 1.0, None, {}, None, False
    for _ in range(4):
        start = {} if scale == 1.0 else {"modulus_scale": scale}
        floor_at = floor_at or scale
        data = build_dataset(list(recordings), _prediction(forward, recordings, start), model.model_form_share,
                             left_out, model.pressure_form_share, design_floor(floor_at) if design_floor else None)
        fitter = Fitter(data, forward)
        calibration = calibration_parameters(scale, frame, density)
        decision = decide(fitter, effects, seed=model.bootstrap_seed, calibration=calibration,
                          main=ladder_parameter(model.stiffening_top_mpa))
        pinned = modulus_pinned(decision, calibration)  # not a batch of rubber, and no effect frees it
        past = past_maximum(decision.final.fit.predictions, data)  # the rubber cannot reach the recordings
        if check is None and (pinned or past or baseline_pinned(decision, calibration)):
            least = reach_scale(_prediction(forward, recordings, {}))
            check = check_material(fitter, frame, design.material or "rubber", least, density)
            if not check.in_window and (pinned or past or other_rubber_fits(check, decision, DCHI2_MIN)):
                scale, floor_at = check.scale, None
                continue
            if not check.in_window:
                check = None  # an effect explains what another rubber would not: judged in the window
        fitted = decision.baseline.fit.values.get("modulus_scale", scale)
        if design_floor and not refloored and abs(np.log(fitted / floor_at)) > np.log(FLOOR_RESCALE):
            floor_at, refloored = fitted, True  # the recordings read on the design's runs where the fit put them
            continue
        unreached = out_of_reach(decision.final.fit.predictions, data)
        if not unreached:
            break
        left_out = {i: left_out.get(i, np.zeros(len(recordings[i]), bool)) | m for i, m in unreached.items()}
    return Calibrated(data, fitter, decision, calibration, check, left_out)


def _fit_summary(cal: Calibrated) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Where the baseline misses (``mismatch``), and the RMSEs before and after, on all rows and held
    out, of the observable it misses most (``fit``)."""
    data, fitter, base, final = cal.data, cal.fitter, cal.decision.baseline, cal.decision.final
    mismatch = locate(data, by_series(data, _full_z(fitter, base)), residuals=_residuals(data, base))
    observable = mismatch[0]["observable"] if mismatch else _most_gained(data, base, final)
    fit = {
        "observable": observable,
        "rmse_before": _rmse(data, _full_z(fitter, base), observable),
        "rmse_after": _rmse(data, _full_z(fitter, final), observable),
        "heldout_rmse_before": _rmse(data, base.heldout_z, observable),
        "heldout_rmse_after": _rmse(data, final.heldout_z, observable),
    }
    return mismatch, fit


def _most_gained(data: DataSet, base: Candidate, final: Candidate) -> str:
    """The observable on which ``final`` gains most held-out chi-square over ``base`` (the first series' when
    no window stands out and the two are alike): where a misfit too spread out to locate was removed."""
    gains: dict[str, float] = {}
    for s, zb, zf in zip(data.series, by_series(data, base.heldout_z), by_series(data, final.heldout_z), strict=True):
        gains[s.observable] = gains.get(s.observable, 0.0) + float(np.sum(zb ** 2) - np.sum(zf ** 2))
    best = max(gains, key=gains.get)
    return best if gains[best] > 0 else data.series[0].observable


def _named_effects(cal: Calibrated, effects: list, recordings: Sequence[Recording], mismatch: list[dict[str, Any]],
                   fit: dict[str, Any], unit: str) -> tuple[list[dict[str, Any]], list[str]]:
    """The ``missing_physics`` entries of the accepted effects, and the words of their rig checks."""
    final = cal.decision.final
    by_name = {e.name: e for e in effects}
    missing, rig_notes = [], []
    for cand in cal.decision.accepted:
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
            "at_bound": cand.at_bound,
            "explanation": explain.explanation(effect, values, spread, mismatch, fit["heldout_rmse_before"],
                                               fit["heldout_rmse_after"], unit, cand.at_bound),
        })
        if name == "dead_volume":
            rig_notes += _check_rig(missing[-1], recordings, final.fit.predictions)
    return missing, rig_notes


def _summary(cal: Calibrated, effects: list, fit: dict[str, Any], unit: str, missing: list[dict[str, Any]]
             ) -> tuple[list[dict[str, Any]], str]:
    """Where the final model still misses (when unexplained; the baseline's misfit is the mismatch),
    and the verdict's words: the named effects' explanations, what is left, or that nothing is missing."""
    data, fitter, decision = cal.data, cal.fitter, cal.decision
    final = decision.final
    judged = final.predictive_z if final.predictive_z is not None else final.heldout_z
    excess = excess_sigma(float(np.sum(judged ** 2)), judged.size)  # what the verdict was judged on
    left = (locate(data, by_series(data, _full_z(fitter, final)), residuals=_residuals(data, final))
            if decision.unexplained else [])
    if decision.unexplained:  # what was named still counts; what is left is said after it
        return left, " ".join([*(m["explanation"] for m in missing),
                               explain.unexplained(fit["heldout_rmse_after"], unit, excess, [e.name for e in effects],
                                                   left[0]["description"] if left else None,
                                                   left[0]["observable"] if left else None)])
    if not missing:
        return left, explain.nothing_missing(fit["heldout_rmse_after"], unit, excess)
    return left, " ".join(m["explanation"] for m in missing)


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
                                                entry["uncertainty"]["dead_volume"] or 0.0, bound)
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
