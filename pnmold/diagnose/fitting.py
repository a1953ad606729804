"""Least-squares fits of a model to a :class:`DataSet`, whole or with blocks held out.

A *hypothesis* is the nominal model plus zero or more effects; its free parameters are
the calibration (``modulus_scale``) and each effect's parameters, all bounded. Fits use
scipy's trust-region reflective least squares on the pooled z-scores
``(measured - predicted) / noise``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from pnmold.errors import SolveError

from .data import PRESSURE_FORM_SHARE, DataSet

#: a prediction's shares of a row out of the model's reach (its pressure; read by volume, its volume)
REACH = ("pressure_excess", "volume_excess")
#: z-score given to rows the model could not predict
FAILED_Z = 1e4
#: start points optimised from (more are screened by their misfit first)
MAX_STARTS = 2
#: forward results kept by their exact parameters (a held-out or bootstrap refit starts where
#: the full fit ended: its first point and Jacobian columns repeat), at most this many and this many bytes
#: (assumed: a tenth of a 2-core machine's memory; 512 predictions of 2000 rows take ~80 MB)
KEPT_PREDICTIONS = 512
KEPT_BYTES = 200_000_000

#: forward(effects, calibration) -> one prediction (columns by name) per recording;
#: ``effects`` holds ``name`` -> value and ``name.param`` -> value (docs/effects.md)
Forward = Callable[[dict[str, float], dict[str, float]], list[dict[str, np.ndarray]]]

@dataclass(frozen=True)
class Parameter:
    key: str  # "modulus_scale", "gravity", "viscoelasticity.tau_s"
    start: float
    low: float
    high: float
    calibration: bool = False


@dataclass(frozen=True)
class Hypothesis:
    """The nominal model plus ``effects`` (names), with the parameters to fit."""

    effects: tuple[str, ...]
    parameters: tuple[Parameter, ...]

    @property
    def label(self) -> str:
        return " + ".join(self.effects) or "baseline"


@dataclass
class Fit:
    hypothesis: Hypothesis
    x: np.ndarray
    chi2: float  # sum of squared z-scores on the rows fitted
    n: int
    predictions: list[dict[str, np.ndarray]] = field(default_factory=list)

    @property
    def values(self) -> dict[str, float]:
        return {p.key: float(v) for p, v in zip(self.hypothesis.parameters, self.x, strict=True)}


def split_values(h: Hypothesis, x: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
    effects, calib = {}, {}
    for p, v in zip(h.parameters, x, strict=True):
        (calib if p.calibration else effects)[p.key] = float(v)
    return effects, calib


def zscores(data: DataSet, predictions: list[dict[str, np.ndarray]]) -> np.ndarray:
    """(measured - predicted) / noise for every row of every series, concatenated. A row the model
    cannot reach because its pressure lies past the model's pressure maximum (the prediction's
    ``pressure_excess``, a share of the row's pressure; its prediction the state at the maximum)
    adds that share over the model's form error in pressure, in quadrature: continuous at the
    maximum, and growing with how far out of reach the row is. A row read by its volume past the volume
    the model can take (``volume_excess``, a share of the row's volume) counts alike."""
    out = []
    for s in data.series:
        pred = predictions[s.recording]
        f = np.asarray(pred[s.observable], float)[s.rows]
        z = (s.y - f) / s.sigma
        excess = sum(np.asarray(pred[k], float)[s.rows] for k in REACH if k in pred)
        if not np.isscalar(excess):
            z = np.where(z < 0, -1.0, 1.0) * np.hypot(z, excess / (s.pressure_share or PRESSURE_FORM_SHARE))
        out.append(z)
    return np.concatenate(out)


def owned(prediction: list[dict[str, np.ndarray]]) -> list[dict[str, np.ndarray]]:
    """The prediction with every column an array of its own. A column the model returns as a view (the tip:
    one node of the rod's (rows, nodes, 2) array) keeps the whole array it views alive: kept hundreds of
    times, that was tens of floats a row per prediction, most of a diagnosis's memory."""
    return [{k: np.array(v) if isinstance(v, np.ndarray) and v.base is not None else v for k, v in cols.items()}
            for cols in prediction]


def _nbytes(prediction: list[dict[str, np.ndarray]] | SolveError) -> int:
    if isinstance(prediction, SolveError):
        return 0
    return sum(v.nbytes for cols in prediction for v in cols.values() if isinstance(v, np.ndarray))


class Fitter:
    """Fits hypotheses to ``data`` through ``forward``; counts model evaluations (the forward
    runs: a prediction at parameters already evaluated is the kept one, the model being
    deterministic)."""

    def __init__(self, data: DataSet, forward: Forward):
        self.data = data
        self.forward = forward
        self.evaluations = 0
        self._kept: dict[tuple, list[dict[str, np.ndarray]] | SolveError] = {}
        self._sizes: dict[tuple, int] = {}

    def predict(self, h: Hypothesis, x: np.ndarray) -> list[dict[str, np.ndarray]]:
        effects, calib = split_values(h, x)
        key = (tuple(sorted(effects.items())), tuple(sorted(calib.items())))
        if key not in self._kept:
            self.evaluations += 1
            try:
                self._kept[key] = owned(self.forward(effects, calib))
            except SolveError as err:
                self._kept[key] = err
            self._sizes[key] = _nbytes(self._kept[key])
            while len(self._kept) > 1 and (len(self._kept) > KEPT_PREDICTIONS
                                           or sum(self._sizes.values()) > KEPT_BYTES):
                oldest = next(iter(self._kept))
                del self._kept[oldest], self._sizes[oldest]
        got = self._kept[key]
        if isinstance(got, SolveError):
            raise got
        return got

    def z(self, h: Hypothesis, x: np.ndarray, weight: np.ndarray | None = None) -> np.ndarray:
        """z-scores of every row; with ``weight`` (rows' multiplicities, e.g. 0 for held-out
        rows, bootstrap counts) the rows with weight > 0, scaled by sqrt(weight). Parameters
        the model cannot solve for (no equilibrium) score as a very bad fit."""
        try:
            z = zscores(self.data, self.predict(h, x))
        except SolveError:
            z = np.full(self.data.n, FAILED_Z)
        z = np.where(np.isfinite(z), z, FAILED_Z)
        if weight is None:
            return z
        keep = weight > 0
        return z[keep] * np.sqrt(weight[keep])

    def fit(self, h: Hypothesis, weight: np.ndarray | None = None, starts: list[np.ndarray] | None = None,
            max_nfev: int = 60) -> Fit:
        """Best parameters of ``h`` on the rows weighted by ``weight`` (all rows when None)."""
        lo = np.array([p.low for p in h.parameters])
        hi = np.array([p.high for p in h.parameters])
        starts = [np.clip(x, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))
                  for x in (starts or [np.array([p.start for p in h.parameters])])]
        if len(starts) > MAX_STARTS:  # screen: optimise from the few best start points only
            screen = [float(np.sum(self.z(h, x, weight) ** 2)) for x in starts]
            starts = [starts[i] for i in np.argsort(screen)[:MAX_STARTS]]
        best = None
        for x0 in starts:
            res = least_squares(lambda x: self.z(h, x, weight), x0, bounds=(lo, hi), x_scale=hi - lo,
                                diff_step=1e-4, max_nfev=max_nfev)
            chi2 = float(np.sum(res.fun ** 2))
            if best is None or chi2 < best.chi2:
                best = Fit(h, res.x, chi2, int(res.fun.size))
        return best

    def heldout(self, h: Hypothesis, start: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """z-scores of every row predicted by a fit that did not see its fold; and the
        per-fold fitted parameters."""
        folds = self.data.folds
        z = np.empty(folds.size)
        xs = []
        for k in np.unique(folds):
            train = folds != k
            fit = self.fit(h, train.astype(float), [start], max_nfev=30)
            xs.append(fit.x)
            z[~train] = self.z(h, fit.x)[~train]
        return z, xs
