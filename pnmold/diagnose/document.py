"""The diagnosis as its JSON document, schema ``pnmold.diagnosis/1`` (``docs/json-schemas.md``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from pnmold.recording import Recording

from . import explain
from .data import DataSet
from .decide import Candidate, Decision
from .fitting import Fitter, Parameter

if TYPE_CHECKING:
    from .calibrate import MaterialCheck
    from .inputs import DesignRef

SCHEMA = "pnmold.diagnosis/1"


@dataclass(frozen=True, eq=False)
class Calibrated:
    """What the calibration leaves: the data set as last built, its fitter and decision, the
    calibration parameters, the material check (None: not made, or in the window) and, per recording
    index, the rows left out as out of the model's reach."""

    data: DataSet
    fitter: Fitter
    decision: Decision
    calibration: tuple[Parameter, ...]
    check: MaterialCheck | None
    left_out: dict[int, np.ndarray]


@dataclass(frozen=True, eq=False)
class Findings:
    """What a diagnosis says: the notes on the calibration, where the baseline misses (``mismatch``)
    and the final model still does (``left``), the fit's RMSEs (``fit``), the named effects'
    entries (``missing``) and the summary."""

    notes: list[str]
    mismatch: list[dict[str, Any]]
    fit: dict[str, Any]
    missing: list[dict[str, Any]]
    left: list[dict[str, Any]]
    summary: str


def diagnosis_document(design: DesignRef, recordings: Sequence[Recording], cal: Calibrated, found: Findings,
                       seconds: float) -> dict[str, Any]:
    """The document of a diagnosis: ``cal`` the calibrated search, ``found`` what was said of it,
    ``seconds`` the wall time it took (rounded to the millisecond)."""
    base, final, data, decision = cal.decision.baseline, cal.decision.final, cal.data, cal.decision
    fit = found.fit
    return {
        "schema": SCHEMA,
        "design": design.as_json(),
        "recordings": [{"path": r.path, "kind": r.kind, "rows": len(r), "orientation": r.orientation,
                        "conversions": dict(r.conversions)} for r in recordings],
        "baseline": {"calibrated": {k: round(v, 6) for k, v in base.fit.values.items()},
                     "rmse": fit["rmse_before"], "heldout_rmse": fit["heldout_rmse_before"]},
        "calibration": {"final": {k: round(v, 6) for k, v in final.fit.values.items()
                                  if k in {p.key for p in cal.calibration}},
                        "material_check": None if cal.check is None else cal.check.as_json(), "notes": found.notes},
        "noise": {s.name: s.level for s in data.series},
        "noise_parts": {s.name: {"measurement": s.measurement, "model_form": s.model_form,
                                  "design_uncertainty": s.design} for s in data.series},
        "mismatch": found.mismatch,
        "remaining_mismatch": found.left,
        "missing_physics": found.missing,
        "unexplained": bool(decision.unexplained),
        "fit": {k: (round(v, 6) if isinstance(v, float) else v) for k, v in fit.items()},
        "candidates": [_candidate_entry(c) for c in decision.ranked],
        "summary": found.summary,
        "alternatives": _alternatives(decision),
        "model_evaluations": cal.fitter.evaluations,
        "seconds": round(seconds, 3),
    }


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
