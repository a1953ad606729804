"""Where the model cannot reach the recordings: rows past its pressure maximum, rows where it has no
equilibrium, rows beyond the pressure its FE characterisation solved (``docs/diagnosis.md``, ``docs/fe.md``)."""

from __future__ import annotations

import numpy as np

from pnmold.errors import SolveError

from .data import PRESSURE_FORM_SHARE, DataSet
from .inputs import Reach

#: the share of rows beyond the FE's characterisation above which a diagnosis is refused (assumed)
REFUSE_BEYOND_FE = 0.2


def past_maximum(predictions: list[dict[str, np.ndarray]], data: DataSet) -> bool:
    """Any kept row past the model's pressure maximum (``pressure_excess``): the modulus the window
    allows cannot reach the recordings."""
    return bool(rows_where(predictions, data, "pressure_excess").any())


def out_of_reach(predictions: list[dict[str, np.ndarray]], data: DataSet) -> dict[int, np.ndarray]:
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


def rows_where(predictions: list[dict[str, np.ndarray]], data: DataSet, key: str) -> np.ndarray:
    """Per kept row of every recording (once, whatever its observables), the prediction's flag ``key``."""
    kept = {s.recording: s.rows for s in data.series}
    return np.concatenate([np.asarray(predictions[i].get(key, np.zeros(len(data.recordings[i]))), float)[rows] > 0
                           for i, rows in kept.items()])


def extrapolation(predictions: list[dict[str, np.ndarray]], data: DataSet, reach: Reach | None,
                  scale: float = 1.0) -> list[str]:
    """Where the final model's rows lie past the pressures the FE solved: said, and refused (SolveError)
    when that is most of the data and the FE stopped short of full bend other than at a pressure maximum.
    Rows past the FE's last solved step are not read off any law (the reduced model holds them at that
    step, :meth:`pnmold.physics.rom.ReducedModel.run`; past a pressure maximum it has no equilibrium):
    said, with how they were judged. Rows flagged ``beyond_fe`` without an excess (a curve read by volume
    past the model's own pressure grid) are said as extrapolated. ``scale``: the calibrated modulus scale,
    by which the FE's pressures carry over to the recordings'."""
    past = rows_where(predictions, data, "pressure_excess")
    full = rows_where(predictions, data, "volume_excess")  # read by volume: more than the model can take
    beyond = int(np.sum(rows_where(predictions, data, "beyond_fe") & ~past & ~full))
    total = past.size
    if reach is None or not (beyond or past.any() or full.any()):
        return []
    top = reach.max_pressure_kpa
    where = (f"{top:.4g} kPa" if abs(scale - 1.0) < 1e-6 else
             f"{top * scale:.4g} kPa of the recordings ({top:.4g} kPa with the design's rubber, times the "
             f"calibrated modulus scale {scale:.3g})")
    notes = []
    short = reach.full_bend_pressure_kpa is None and reach.reason
    if past.any() and short and not reach.at_maximum and past.sum() > REFUSE_BEYOND_FE * total:
        raise SolveError(f"{int(past.sum())} of {total} rows need the model beyond {where}, where the FE's "
                         f"characterisation of the design stopped ({reach.reason}): the model reads no law past "
                         "the FE's last solved step. Check the design (the FE must reach the recordings' bend) before "
                         "diagnosing.")
    if past.any():
        share = data.series[0].pressure_share or PRESSURE_FORM_SHARE
        counts = (f"each counts by the share of its pressure the model cannot hold ({100 * share:.3g} % of the "
                  f"pressure is one standard deviation)")
        if reach.at_maximum:
            notes.append(f"{int(past.sum())} of {total} rows lie past the model's pressure maximum ({where}; "
                         f"{reach.reason or 'the FE'}): it has no equilibrium there under pressure control, so "
                         f"{counts}. A volume-driven rig follows the actuator past such a maximum; the model does not.")
        else:
            notes.append(f"{int(past.sum())} of {total} rows lie past the last pressure the FE solved ({where}; "
                         f"{reach.reason or 'the FE'}): the model reads no law past it, so each is held at that "
                         f"last state and {counts}.")
    if full.any():
        share = data.series[0].pressure_share or PRESSURE_FORM_SHARE
        notes.append(f"{int(full.sum())} of {total} rows read by the volume their rig set hold more than the model "
                     f"takes up to its pressure maximum ({where}; {reach.reason or 'the FE'}): each counts by "
                     f"the share of its volume the model cannot take ({100 * share:.3g} % of the volume is one "
                     f"standard deviation).")
    if not beyond:
        return notes
    if short and beyond > REFUSE_BEYOND_FE * total:
        raise SolveError(f"{beyond} of {total} rows need the model beyond {where}, where the FE's "
                         f"characterisation of the design stopped ({reach.reason}): the answer would rest on "
                         f"extrapolation. Check the design (the FE must reach the recordings' bend) before diagnosing.")
    return [*notes, f"{beyond} of {total} rows lie beyond the pressure the FE characterised ({where}"
            + (f", where its solve stopped: {reach.reason}" if short else ", past full bend") + "): the model "
            "extrapolates its law there."]
