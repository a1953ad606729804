"""``diagnose``: recordings against the model -> a :class:`Diagnosis` (schema pnmold.diagnosis/1)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pnmold.recording import Recording

from . import explain
from .data import DataSet, build_dataset
from .decide import Candidate, Decision, decide, excess_sigma
from .fitting import Fitter, Forward, zscores
from .locate import locate

SCHEMA = "pnmold.diagnosis/1"
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


def _full_z(fitter: Fitter, c: Candidate) -> np.ndarray:
    return zscores(fitter.data, c.fit.predictions)


def diagnose(design_entry: dict[str, str], recordings: Sequence[Recording], forward: Forward,
             effects: list, *, seed: int = 0) -> Diagnosis:
    """Calibrate, locate, rank, fit, accept; ``effects`` are catalogue entries to consider
    (those whose kinds include a recorded kind)."""
    t0 = time.perf_counter()
    kinds = {r.kind for r in recordings}
    effects = [e for e in effects if kinds & set(e.kinds)]
    nominal = forward({}, {})
    data = build_dataset(list(recordings), nominal)
    fitter = Fitter(data, forward)
    decision = decide(fitter, effects, seed=seed)
    base, final = decision.baseline, decision.final
    mismatch = locate(data, by_series(data, _full_z(fitter, base)))
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
    missing = []
    for cand in decision.accepted:
        name = cand.fit.hypothesis.effects[-1]
        effect = by_name[name]
        values, spread = explain.effect_values(cand, effect)
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
    excess = excess_sigma(final.heldout_chi2, final.heldout_z.size)
    if decision.unexplained:
        summary = explain.unexplained(fit["heldout_rmse_after"], unit, excess, [e.name for e in effects])
    elif not missing:
        summary = explain.nothing_missing(fit["heldout_rmse_after"], unit, excess)
    else:
        summary = " ".join(m["explanation"] for m in missing)
    doc = {
        "schema": SCHEMA,
        "design": design_entry,
        "recordings": [{"path": r.path, "kind": r.kind, "rows": len(r), "orientation": r.orientation,
                        "conversions": dict(r.conversions)} for r in recordings],
        "baseline": {"calibrated": {k: round(v, 6) for k, v in base.fit.values.items()},
                     "rmse": fit["rmse_before"], "heldout_rmse": fit["heldout_rmse_before"]},
        "noise": {s.name: s.sigma for s in data.series},
        "mismatch": mismatch,
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


def _candidate_entry(c: Candidate) -> dict[str, Any]:
    return {"effect": c.label, "heldout_chi2_per_point": round(c.heldout_chi2 / c.heldout_z.size, 4),
            "heldout_chi2_gain": round(c.gain, 1), "heldout_gain_t": round(c.t_gain, 2),
            "excess_removed": round(c.excess_share, 3),
            "bootstrap_wins": round(c.stability, 3), "plausible": c.plausible,
            "parameters": {k: round(v, 6) for k, v in c.fit.values.items()}, "notes": c.notes}


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
