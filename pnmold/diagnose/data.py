"""Recordings as one standardised data set: observables, noise, branches and blocks.

Every recording contributes its observables (bending: tip x and z; pv: volume, or the pressure
when read by the volume its rig set, :func:`pnmold.physics.protocol.read_by_volume`; force:
force; step: the inlet pressure and, when recorded, the bend angle, the metered flow, the far
chamber's pressure and the cavity's volume change). Each observable of each
recording gets a noise level estimated from the data itself, so residuals of different
units can be pooled as z-scores. Rows are grouped into *branches* (one cycle's inflation
or deflation of one recording) and branches into short contiguous *blocks*; held-out
error is computed by leaving out whole blocks, never single rows (docs/diagnosis.md: samples
next to each other are correlated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pnmold.physics.protocol import read_by_volume
from pnmold.recording import Recording
from pnmold.recording.reduce import averaged_rows

#: observables a diagnosis compares, per recording kind (in the recording's units)
OBSERVABLES = {
    "bending": ("tip_x_mm", "tip_z_mm"),
    "pv": ("volume_ml",),
    "force": ("force_n",),
    "step": ("pressure_kpa", "bend_angle_deg", "flow_slpm", "pressure_far_kpa", "volume_ml"),
}
#: the model's own form error, as a share of each observable's range in a recording: a floor under
#: the noise, so that "significant" means beyond what the model could ever explain (assumed from what
#: was measured: the reduced model misses the FE by 0.6-1.8 % of the length over a template's whole
#: curve, docs/reduced-model.md; the FE's mesh error, about 2 % of the full-bend pressure, is mostly a
#: stiffness scale the modulus calibration absorbs). Repeated cycles measure what the rig and the rubber
#: do not repeat, not how far the model is from the actuator: the floor stands beside them.
MODEL_FORM_SHARE = 0.01
#: the model's form error in pressure: a state the model reaches at p, the actuator may reach at
#: p (1 +- this) (assumed from what was measured: the FE's full-bend pressure moved 1.2-1.9 % between
#: the build mesh and a 1.6x finer one, ``benchmarks/fem.py``, docs/fe.md; the reduced model reads the
#: FE's law in pressure). On a quasi-static recording it is carried through the model's slope dy/dp row
#: by row: where the bend runs away at a nearly constant pressure (near a pressure maximum), no model can
#: place the bend better than it places the pressure.
PRESSURE_FORM_SHARE = 0.02
#: recording kinds whose rows are indexed by a slowly varied pressure (the slope floor applies)
QUASI_STATIC = ("bending", "pv", "force")
#: rows per held-out block (at least); a branch of 30 rows gives 5 blocks
BLOCK_ROWS = 6
FOLDS = 5
#: a short branch (a real rig's 15 increments) is still cut into as many blocks as there are folds
#: while each keeps this many rows: with 2 blocks every held-out fold would be half the curve, the
#: test an extrapolation from one half to the other (across a pressure plateau: no model passes it)
MIN_BLOCK_ROWS = 3


@dataclass(frozen=True, eq=False)
class Series:
    """One observable of one recording."""

    recording: int  # index into the list of recordings
    observable: str
    y: np.ndarray  # measured values, in the recording's units
    sigma: np.ndarray  # (n,) what the model cannot be asked to explain: measurement noise and model form
    branch: np.ndarray  # (n,) branch id of each row (global over the data set)
    block: np.ndarray  # (n,) block id of each row (global over the data set)
    rows: np.ndarray  # (n,) row indices in the recording
    measurement: float = 0.0  # the measurement noise estimated from the data (same units; RMS over a reduced
    # recording's rows, each the recorded rows' noise over sqrt(the rows it averages))
    model_form: float = 0.0  # the model's form-error floor, RMS over the rows (same units)
    pressure_share: float = PRESSURE_FORM_SHARE  # the model's form error in pressure, a share of it
    design: float = 0.0  # the design's stated dimensional uncertainty, RMS over the rows (same units)

    @property
    def name(self) -> str:
        return f"{self.observable}[{self.recording}]"

    @property
    def level(self) -> float:
        """The noise as one number: the RMS of ``sigma`` over the rows."""
        return float(np.sqrt(np.mean(self.sigma ** 2))) if self.sigma.size else 0.0


@dataclass(frozen=True, eq=False)
class DataSet:
    """All series with their block structure."""

    recordings: tuple[Recording, ...]
    series: tuple[Series, ...]

    @property
    def n(self) -> int:
        return int(sum(s.y.size for s in self.series))

    @property
    def blocks(self) -> np.ndarray:
        return np.concatenate([s.block for s in self.series])

    @property
    def folds(self) -> np.ndarray:
        """Fold id of every row: blocks dealt round-robin, so each fold spans every regime."""
        return self.blocks % FOLDS


def branches_of(rec: Recording) -> np.ndarray:
    """Branch index per row: a new branch where cycle or phase changes, or pressure turns."""
    n = len(rec)
    keys = []
    cycle = rec.columns.get("cycle")
    phase = rec.columns.get("phase")
    for i in range(n):
        keys.append((None if cycle is None else cycle[i], None if phase is None else phase[i]))
    out = np.zeros(n, dtype=int)
    b = 0
    if rec.kind == "step":
        return out
    p = np.asarray(rec.columns["pressure_kpa"], float)
    direction = 0.0
    for i in range(1, n):
        dp = p[i] - p[i - 1]
        turned = direction != 0 and dp != 0 and np.sign(dp) != direction
        if keys[i] != keys[i - 1] or turned:
            b += 1
            direction = 0.0
        if dp != 0:
            direction = float(np.sign(dp))
        out[i] = b
    return out


def noise_sigma(residual: np.ndarray, branch: np.ndarray, floor: float, averaged: np.ndarray | None = None) -> float:
    """Noise from the scatter of second differences of ``residual`` within branches:
    for white noise of level s, y[i-1] - 2 y[i] + y[i+1] has standard deviation s sqrt(6);
    the median absolute deviation keeps a few outliers or a knee from inflating it.

    ``averaged``: per row, how many recorded rows it is the mean of (a reduced recording,
    :mod:`pnmold.recording.reduce`). Row i then has the noise s / sqrt(k_i), each second difference
    s sqrt(1/k[i-1] + 4/k[i] + 1/k[i+1]), and each is divided by its own factor: the result is s, the
    noise of one recorded row, estimated from the kept rows' own scatter (noise that does not average
    down, correlated in time, shows as a larger s: never overconfident)."""
    if averaged is not None:
        return _noise_averaged(residual, branch, floor, averaged)
    d2 = []
    for b in np.unique(branch):
        r = residual[branch == b]
        if r.size >= 3:
            d2.append(r[:-2] - 2.0 * r[1:-1] + r[2:])
    if not d2:
        return floor
    d = np.concatenate(d2)
    mad = float(np.median(np.abs(d - np.median(d))))
    return max(1.4826 * mad / np.sqrt(6.0), floor)


def _noise_averaged(residual: np.ndarray, branch: np.ndarray, floor: float, averaged: np.ndarray) -> float:
    """:func:`noise_sigma` of rows that are means of ``averaged`` recorded rows each."""
    d2 = []
    for b in np.unique(branch):
        on = branch == b
        r, w = residual[on], 1.0 / averaged[on]
        if r.size >= 3:
            d2.append((r[:-2] - 2.0 * r[1:-1] + r[2:]) / np.sqrt(w[:-2] + 4.0 * w[1:-1] + w[2:]))
    if not d2:
        return floor
    d = np.concatenate(d2)
    return max(1.4826 * float(np.median(np.abs(d - np.median(d)))), floor)


def repeat_sigma(residual: np.ndarray, rec: Recording) -> float | None:
    """Noise from the scatter between repeated cycles: each phase of cycles 2, 3, ... (the first
    loading may differ: Mullins) interpolated on the pressures of the first of them; the pooled
    deviation from their mean. None without two such cycles."""
    cycle, phase = rec.columns.get("cycle"), rec.columns.get("phase")
    if cycle is None or phase is None or rec.kind == "step":
        return None
    p = np.asarray(rec.columns["pressure_kpa"], float)
    sq, dof = 0.0, 0
    for ph in ("inflate", "deflate"):
        runs = []
        for c in sorted(set(int(v) for v in cycle) - {1}):
            sel = np.flatnonzero((cycle == c) & (phase == ph))
            if sel.size >= 3:
                order = np.argsort(p[sel])
                runs.append((p[sel][order], residual[sel][order]))
        if len(runs) < 2:
            continue
        grid = runs[0][0]
        stack = np.array([np.interp(grid, x, r) for x, r in runs])
        sq += float(np.sum((stack - stack.mean(axis=0)) ** 2))
        dof += stack.size - grid.size
    return float(np.sqrt(sq / dof)) if dof > 0 else None


def _slope_at(p: np.ndarray, f: np.ndarray, idx: np.ndarray) -> np.ndarray | None:
    """|df/dp| along the rows ``idx`` (repeated pressures averaged to one point), at those rows."""
    grid = np.unique(p[idx])
    if grid.size < 2:
        return None
    mean = np.array([f[idx][p[idx] == g].mean() for g in grid])
    return np.interp(p[idx], grid, np.abs(np.gradient(mean, grid)))


def pressure_form(rec: Recording, prediction: np.ndarray, branch: np.ndarray,
                  share: float = PRESSURE_FORM_SHARE, measured: np.ndarray | None = None) -> np.ndarray:
    """Per row, ``share`` x p x |dy/dp| of the model's ``prediction`` along each branch (0 where
    the recording is not quasi-static). Where the model has no equilibrium (NaN) the ``measured``
    curve's own slope stands in."""
    out = np.zeros(len(rec))
    p = rec.columns.get("pressure_kpa")
    if rec.kind not in QUASI_STATIC or p is None:
        return out
    p, f = np.asarray(p, float), np.asarray(prediction, float)
    for b in np.unique(branch):
        on = np.flatnonzero(branch == b)
        ok = np.isfinite(f[on])
        slope = np.zeros(on.size)
        model = _slope_at(p, f, on[ok])
        if model is not None:
            slope[ok] = model
        if measured is not None and not ok.all() and (own := _slope_at(p, np.asarray(measured, float), on)) is not None:
            slope[~ok] = own[~ok]
        out[on] = share * np.abs(p[on]) * slope
    return out


def observables_of(rec: Recording) -> tuple[str, ...]:
    """The observables a recording gives; a bending test without the tip, its bend angle; a P-V test read
    by its volume (:func:`pnmold.physics.protocol.read_by_volume`), its pressure."""
    if read_by_volume(rec):
        return ("pressure_kpa",)
    found = tuple(c for c in OBSERVABLES[rec.kind] if c in rec.columns)
    if not found and rec.kind == "bending":
        return ("bend_angle_deg",)
    return found


def _within_reach(prediction: dict[str, np.ndarray], name: str) -> np.ndarray:
    """The prediction of ``name``, NaN on rows past the model's pressure maximum (``pressure_excess``):
    there it gives the state at the maximum, whose slope in pressure (zero) is not the actuator's."""
    f = np.asarray(prediction[name], float)
    excess = prediction.get("pressure_excess")
    return f if excess is None else np.where(np.asarray(excess, float) > 0, np.nan, f)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x ** 2))) if x.size else 0.0


def build_dataset(recordings: list[Recording], baseline: list[dict[str, np.ndarray]],
                  model_form_share: float = MODEL_FORM_SHARE, left_out: dict[int, np.ndarray] | None = None,
                  pressure_form_share: float = PRESSURE_FORM_SHARE,
                  design_form: list[dict[str, np.ndarray]] | None = None) -> DataSet:
    """Series for every observable of every recording. Each one's sigma is the measurement noise,
    estimated from the residual against ``baseline`` (a first prediction per recording, which
    removes the curve's own shape): the larger of the scatter of its second differences and of
    the repeated cycles (2, 3, ...); to it is added (in quadrature) the model-form floor,
    ``model_form_share`` of the observable's range in it and, row by row, the baseline's pressure error
    (``pressure_form_share``) carried through its slope (:func:`pressure_form`). ``design_form``: per
    recording, observable -> per row, the standard deviation the design's stated dimensional uncertainty
    gives it (:class:`pnmold.physics.uncertainty.DesignFloor`), added in quadrature always. ``left_out``:
    recording index -> rows the model cannot reach (no equilibrium), left out of every series. A reduced
    recording's row (the mean of k recorded rows, :mod:`pnmold.recording.reduce`) has the measurement
    noise of a recorded row over sqrt(k), or the scatter between its cycles where that is larger."""
    series: list[Series] = []
    branch0 = block0 = 0
    for i, rec in enumerate(recordings):
        branch = branches_of(rec)
        block = np.zeros(len(rec), dtype=int)
        nxt = 0
        for b in np.unique(branch):
            idx = np.where(branch == b)[0]
            nblocks = max(1, idx.size // BLOCK_ROWS, min(FOLDS, idx.size // MIN_BLOCK_ROWS))
            block[idx] = nxt + np.arange(idx.size) * nblocks // idx.size
            nxt += nblocks
        rows = np.flatnonzero(~(left_out or {}).get(i, np.zeros(len(rec), bool)))
        averaged = averaged_rows(rec)  # a reduced recording: each row's measurement noise over sqrt(its rows)
        for name in observables_of(rec):
            y = np.asarray(rec.columns[name], float)
            span = float(np.ptp(y)) if y.size else 1.0
            residual = np.where(np.isfinite(baseline[i][name]), y - baseline[i][name], 0.0)
            repeats = repeat_sigma(residual, rec)  # between cycles, of the rows as kept: it does not average down
            noise = noise_sigma(residual, branch, 1e-4 * max(span, 1e-9), averaged)
            noise = max(noise, repeats or 0.0) if averaged is None else np.maximum(noise / np.sqrt(averaged),
                                                                                   repeats or 0.0)[rows]
            # in pressure directly where the pressure is the observable (read by volume)
            if name == "pressure_kpa" and rec.kind in QUASI_STATIC:
                in_pressure = pressure_form_share * np.abs(y)
            else:
                in_pressure = pressure_form(rec, _within_reach(baseline[i], name), branch, pressure_form_share, y)
            form = np.hypot(model_form_share * span, in_pressure)
            # the design's own uncertainty is not in the rig's repeats: it stays whatever they say
            design = np.asarray(design_form[i].get(name, 0.0) if design_form else 0.0, float) * np.ones(len(rec))
            form, design = form[rows], design[rows]
            series.append(Series(i, name, y[rows], np.sqrt(noise ** 2 + form ** 2 + design ** 2),
                                 branch[rows] + branch0, block[rows] + block0, rows,
                                 noise if averaged is None else _rms(noise), _rms(form), pressure_form_share,
                                 _rms(design)))
        branch0 += int(branch.max(initial=0)) + 1
        block0 += int(block.max(initial=0)) + 1
    return DataSet(tuple(recordings), tuple(series))
