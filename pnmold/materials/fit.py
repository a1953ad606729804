"""Hyperelastic fits of uniaxial tensile (and compression) tests.

Reading the test (pnmold's CSV or a lab's file as published): :mod:`pnmold.materials.tensile`.
The specimen is incompressible and loaded uniaxially: with the stretch ``lam = 1 + eng_strain``,
``I1 = lam**2 + 2/lam`` and the nominal (engineering) stress is

- I1-based models (Yeoh, neo-Hookean): ``P = 2 (lam - lam**-2) dW/dI1`` with
  ``W = sum_i C_i0 (I1 - 3)**i`` (Yeoh N = 3; neo-Hookean N = 1); initial shear modulus ``2 C10``.
- Ogden (Abaqus form) ``W = sum_i 2 mu_i / alpha_i**2 (l1**a_i + l2**a_i + l3**a_i - 3)``:
  ``P = sum_i 2 mu_i / alpha_i (lam**(alpha_i - 1) - lam**(-alpha_i/2 - 1))``;
  initial shear modulus ``sum_i mu_i``.

Constants are in MPa (``c10_mpa``, ``mu1_mpa``), exponents are plain numbers (``alpha1``). A fit
minimises the stress error in MPa or the relative error (:data:`WEIGHTINGS`); ``pnmold material
fit`` (:func:`fit_command`) by default fits the points up to :data:`ACTUATOR_MAX_STRAIN`, where
actuators work, weighting the relative error.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from pnmold.errors import UsageError
from pnmold.fsutil import write_json
from pnmold.materials.tensile import MIN_POINTS as _MIN_POINTS
from pnmold.materials.tensile import Specimen, TensileColumns, TensileData, read_tensile

log = logging.getLogger(__name__)

MODELS = ("yeoh", "neo-hookean", "ogden")
#: the fit "holds" over a strain range when R^2 >= R2_MIN over it and at every point in it
#: |model - measured| <= ERROR_FRACTION * max(|measured|, FLOOR_FRACTION * peak |measured|)
R2_MIN = 0.99
ERROR_FRACTION = 0.10
FLOOR_FRACTION = 0.05
#: a pull-to-failure test has failed at the first point whose stress falls more than this
#: fraction of the peak stress below the highest stress seen so far
FAILURE_DROP = 0.10
#: a fit whose valid range starts above this strain misses the strains an actuator's walls see first
SMALL_STRAIN = 0.5
#: ``pnmold material fit``'s default range: the points up to an engineering strain of 1.5 (150 %), where
#: actuators work. pnmold's FE puts a PneuNet's walls at a largest principal stretch of about 2 at full
#: bend (the fpn 1.93: tests/data/fpn-free-coarse-steps.json; fig-s2a-h5 2.04: its characterisation in
#: pnmold/data/characterisations); 1.5 keeps a margin above that strain of about 1 (assumed).
ACTUATOR_MAX_STRAIN = 1.5
#: how a fit weighs its points: "relative" minimises the relative stress error (with the error floor
#: of the valid range, FLOOR_FRACTION of the peak stress, and a Cauchy loss at ERROR_FRACTION, so a point
#: the fit cannot follow, a slack start say, counts less), "absolute" the stress error in MPa
WEIGHTINGS = ("relative", "absolute")

__all__ = ["ACTUATOR_MAX_STRAIN", "MODELS", "WEIGHTINGS", "FitResult", "Specimen", "TensileColumns", "TensileData",
           "fit_command", "fit_hyperelastic", "read_tensile"]

def _i1_factor(lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(2 (lam - lam^-2), I1 - 3) for incompressible uniaxial loading."""
    return 2.0 * (lam - lam**-2), lam**2 + 2.0 / lam - 3.0


def yeoh_stress(strain, c10: float, c20: float = 0.0, c30: float = 0.0) -> np.ndarray:
    """Nominal uniaxial stress (MPa) of a Yeoh solid at engineering ``strain``."""
    g, i1 = _i1_factor(1.0 + np.asarray(strain, dtype=float))
    return g * (c10 + 2.0 * c20 * i1 + 3.0 * c30 * i1**2)


def ogden_stress(strain, mus, alphas) -> np.ndarray:
    """Nominal uniaxial stress (MPa) of an Ogden solid (Abaqus form) at engineering ``strain``."""
    lam = 1.0 + np.asarray(strain, dtype=float)
    out = np.zeros_like(lam)
    for mu, alpha in zip(mus, alphas, strict=True):
        out += 2.0 * mu / alpha * (lam ** (alpha - 1.0) - lam ** (-alpha / 2.0 - 1.0))
    return out


@dataclass(frozen=True)
class FitResult:
    """A fitted hyperelastic model and how well it reproduces the measured stress."""

    model: str
    constants: dict[str, float]
    r2: float
    rmse_mpa: float
    strain_range: tuple[float, float] | None
    n_points: int
    n_dropped_after_failure: int
    initial_shear_modulus_mpa: float
    source: str
    max_strain: float | None = None
    plot: str | None = None
    read: dict[str, str] | None = None
    #: Yeoh with the higher-order terms kept >= 0 (the default): the unconstrained fit's constants when
    #: it had a negative term, which the design's rules refuse (see :func:`fit_hyperelastic`)
    unconstrained: dict[str, float] | None = None
    #: what the fit minimised (:data:`WEIGHTINGS`): the relative stress error or the error in MPa
    weighting: str = "absolute"
    #: the lowest and highest strain of the points fitted
    fitted_strain_range: tuple[float, float] | None = None
    #: points before failure left out because their strain is above ``max_strain``
    n_above_max_strain: int = 0

    @property
    def held_at_zero(self) -> tuple[str, ...]:
        """The higher-order terms held at 0 because the unconstrained fit made them negative."""
        return tuple(k for k, v in (self.unconstrained or {}).items() if k != "c10_mpa" and v < 0)

    def fitted(self, data: TensileData) -> np.ndarray:
        """Mask of the points of ``data`` that this fit used (before failure, up to ``max_strain``)."""
        mask = np.arange(len(data.strain)) < len(data.strain) - self.n_dropped_after_failure
        return mask & (data.strain <= self.max_strain) if self.max_strain is not None else mask

    def stress(self, strain) -> np.ndarray:
        """The fitted model's nominal stress (MPa) at engineering ``strain``."""
        c = self.constants
        if self.model == "ogden":
            n = sum(1 for k in c if k.startswith("alpha"))
            return ogden_stress(strain, [c[f"mu{i}_mpa"] for i in range(1, n + 1)],
                                [c[f"alpha{i}"] for i in range(1, n + 1)])
        return yeoh_stress(strain, c["c10_mpa"], c.get("c20_mpa", 0.0), c.get("c30_mpa", 0.0))

    def to_json(self) -> dict:
        """Plain JSON: the constants by name with units, both nested and at the top level."""
        out = {"model": self.model, "constants": dict(self.constants), **self.constants,
               "initial_shear_modulus_mpa": self.initial_shear_modulus_mpa,
               "r2": self.r2, "rmse_mpa": self.rmse_mpa,
               "strain_range": list(self.strain_range) if self.strain_range else None,
               "strain_range_rule": {"r2_min": R2_MIN, "max_relative_error": ERROR_FRACTION,
                                     "error_floor_fraction_of_peak_stress": FLOOR_FRACTION},
               "n_points": self.n_points, "n_dropped_after_failure": self.n_dropped_after_failure,
               "max_strain": self.max_strain, "n_above_max_strain": self.n_above_max_strain,
               "fitted_strain_range": list(self.fitted_strain_range) if self.fitted_strain_range else None,
               "weighting": self.weighting, "source": self.source}
        if self.plot:
            out["plot"] = self.plot
        if self.read:
            out["read"] = dict(self.read)
        if self.unconstrained:
            out["held_at_zero"] = list(self.held_at_zero)
            out["unconstrained"] = dict(self.unconstrained)
        return out

    def scope(self) -> str:
        """One line for a person: the strains fitted, how the points were weighed, what was left out."""
        a, b = self.fitted_strain_range or (math.nan, math.nan)
        line = f"fitted: strain {a:.3g} to {b:.3g}, {self.n_points} points, weighting the {self.weighting} stress error"
        if self.n_above_max_strain:
            line += (f"; {self.n_above_max_strain} points above strain {self.max_strain:g} left out "
                     "(--max-strain full fits them)")
        if self.n_dropped_after_failure:
            line += f"; {self.n_dropped_after_failure} points after failure dropped"
        return line

    def summary(self) -> str:
        """One line for a person: the constants, R^2 and the valid strain range."""
        consts = ", ".join(f"{k} = {v:.4g}" for k, v in self.constants.items())
        rng = (f"strain {self.strain_range[0]:.3g} to {self.strain_range[1]:.3g}" if self.strain_range
               else "no strain range meets the tolerance")
        line = f"{self.model}: {consts}; R2 = {self.r2:.5f}, RMSE = {self.rmse_mpa:.3g} MPa; holds over {rng}"
        if self.held_at_zero:
            free = ", ".join(f"{k} = {v:.4g}" for k, v in self.unconstrained.items())
            line += (f"; {' and '.join(self.held_at_zero)} held at 0, as a design's [material] requires (a negative "
                     f"term softens the rubber past the fitted strains and can lose stability; unconstrained, "
                     f"--allow-negative: {free})")
            if self.strain_range is None or self.strain_range[0] > SMALL_STRAIN:
                line += ("; held so, it does not hold at small strains: fit over the strains the actuator's walls "
                         "see (--max-strain, e.g. 3)")
        return line


def _before_failure(data: TensileData) -> int:
    """Number of leading tension points recorded before the specimen failed."""
    stress = data.stress_mpa
    tension = data.strain >= 0
    if not tension.any():
        return len(stress)
    peak = float(stress[tension].max())
    running = -math.inf
    for i, (s, t) in enumerate(zip(stress, tension, strict=True)):
        if not t:
            continue
        if s < running - FAILURE_DROP * abs(peak):
            return i
        running = max(running, s)
    return len(stress)


def _goodness(measured: np.ndarray, predicted: np.ndarray) -> tuple[float, float]:
    res = predicted - measured
    ss_tot = float(np.sum((measured - measured.mean()) ** 2))
    r2 = 1.0 - float(np.sum(res**2)) / ss_tot if ss_tot > 0 else -math.inf
    return r2, float(np.sqrt(np.mean(res**2)))


def valid_strain_range(strain: np.ndarray, measured: np.ndarray, predicted: np.ndarray) -> tuple[float, float] | None:
    """The largest strain range over which the fit holds (lowest first on ties), or None.

    Every point in it has ``|error| <= ERROR_FRACTION * max(|stress|, FLOOR_FRACTION * peak)``
    (the local relative error, with a floor near zero stress; a toe-region point at the start
    of a test can fall outside) and R^2 over it is >= R2_MIN (trimmed from its worse end).
    """
    order = np.argsort(strain, kind="stable")
    e, s, p = strain[order], measured[order], predicted[order]
    tol = ERROR_FRACTION * np.maximum(np.abs(s), FLOOR_FRACTION * float(np.max(np.abs(s))))
    ok = np.abs(p - s) <= tol
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
    runs = list(zip(edges[::2], edges[1::2], strict=True))  # [start, stop) of each run of ok points
    if not runs:
        return None
    lo, hi = max(runs, key=lambda r: (r[1] - r[0], -r[0]))
    ratio = np.abs(p - s) / tol
    while hi - lo >= _MIN_POINTS and _goodness(s[lo:hi], p[lo:hi])[0] < R2_MIN:
        lo, hi = (lo + 1, hi) if ratio[lo] >= ratio[hi - 1] else (lo, hi - 1)
    return (float(e[lo]), float(e[hi - 1])) if hi - lo >= _MIN_POINTS else None


def _relative(s: np.ndarray, weighting: str) -> tuple[np.ndarray | None, dict]:
    """The stress each residual is divided by (None: absolute weighting) and the loss of
    ``least_squares``, for a weighting of :data:`WEIGHTINGS`."""
    if weighting == "absolute":
        return None, {}
    floor = max(FLOOR_FRACTION * float(np.max(np.abs(s))), np.finfo(float).tiny)
    return np.maximum(np.abs(s), floor), {"loss": "cauchy", "f_scale": ERROR_FRACTION}


def _fit_yeoh(e: np.ndarray, s: np.ndarray, order: int, nonnegative: bool,
              weighting: str = "absolute") -> dict[str, float]:
    g, i1 = _i1_factor(1.0 + e)
    basis = np.column_stack([g, 2 * g * i1, 3 * g * i1**2][:order])
    scale = np.max(np.abs(basis), axis=0)
    scale[scale == 0] = 1.0
    a = basis / scale
    per, loss = _relative(s, weighting)
    w = np.ones_like(s) if per is None else 1.0 / per
    guess = np.linalg.lstsq(a * w[:, None], s * w, rcond=None)[0]
    # C10 > 0 keeps the initial shear modulus positive; higher orders free unless asked
    lo = np.array([1e-12 * scale[0]] + [0.0 if nonnegative else -np.inf] * (order - 1))
    guess = np.clip(guess, lo + 1e-12, np.inf)
    sol = least_squares(lambda x: (a @ x - s) * w, guess, bounds=(lo, np.inf), method="trf",
                        x_scale="jac", ftol=1e-15, xtol=1e-15, gtol=1e-15, **loss)
    x = np.where((lo == 0.0) & (sol.x <= 1e-12 * np.abs(sol.x).max()), 0.0, sol.x)  # a term on its bound is 0
    names = ("c10_mpa", "c20_mpa", "c30_mpa")[:order]
    return {n: float(v) for n, v in zip(names, x / scale, strict=True)}


def _fit_ogden(e: np.ndarray, s: np.ndarray, terms: int, weighting: str = "absolute") -> dict[str, float]:
    """Multi-start fit; each term keeps mu_i * alpha_i > 0 (signs fixed per start)."""
    starts = {1: [(2.0,), (5.0,), (-2.0,), (1.0,)],
              2: [(2.0, 5.0), (1.5, 8.0), (2.0, -2.0), (3.0, -3.0), (1.0, 4.0), (0.5, 3.0)]}[terms]
    scale = max(float(np.max(np.abs(s))), 1e-12)
    per, loss = _relative(s, weighting)
    per = scale if per is None else per  # absolute: the error over the peak stress
    best, best_cost = None, math.inf
    for alphas in starts:
        signs = np.sign(alphas)
        lo = np.concatenate([np.where(signs > 0, 0.0, -np.inf), np.where(signs > 0, 0.1, -20.0)])
        hi = np.concatenate([np.where(signs > 0, np.inf, 0.0), np.where(signs > 0, 20.0, -0.1)])
        x0 = np.concatenate([signs * scale / (terms * 10.0), alphas])

        def resid(x):
            with np.errstate(over="ignore", invalid="ignore"):
                r = (ogden_stress(e, x[:terms], x[terms:]) - s) / per
            return np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6)

        try:
            sol = least_squares(resid, x0, bounds=(lo, hi), method="trf", max_nfev=4000, **loss)
        except ValueError:
            continue
        if sol.cost < best_cost:
            best, best_cost = sol.x, sol.cost
    if best is None:
        raise UsageError("the Ogden fit found no solution from any starting point")
    out = {}
    for i in range(terms):
        out[f"mu{i + 1}_mpa"] = float(best[i])
        out[f"alpha{i + 1}"] = float(best[terms + i])
    return out


def fit_hyperelastic(data: TensileData, model: str = "yeoh", *, terms: int = 2, nonnegative: bool = True,
                     max_strain: float | None = None, weighting: str = "absolute") -> FitResult:
    """Fit an incompressible hyperelastic model to uniaxial engineering stress-strain data.

    Parameters
    ----------
    data : the test (see :func:`read_tensile`); points after failure are dropped.
    model : ``"yeoh"`` (C10 > 0, C20 and C30 free), ``"neo-hookean"`` or ``"ogden"``.
    terms : number of Ogden terms (1 or 2).
    nonnegative : Yeoh only: also keep C20, C30 >= 0 (the default), as the design's ``[material]`` rules
        require: a negative higher-order term makes the rubber soften past the strains it was fitted
        over, and the FE's Newton then meets a material that loses stability (Drucker) at large
        stretch. When the unconstrained fit has a negative term, the result keeps it in
        ``unconstrained`` and names the held terms; ``False`` returns the unconstrained fit.
    max_strain : fit only the points up to this strain (e.g. the strains an actuator's walls reach,
        :data:`ACTUATOR_MAX_STRAIN`); None: every point before failure.
    weighting : ``"absolute"`` minimises the stress error in MPa, ``"relative"`` the relative error
        (:data:`WEIGHTINGS`), so the small stresses at small strain count as much as the large ones.
    """
    model = model.lower().replace("_", "-")
    if model in ("neohookean", "neo hookean"):
        model = "neo-hookean"
    if model not in MODELS:
        raise UsageError(f"unknown model {model!r}; models: {', '.join(MODELS)}")
    if terms not in (1, 2):
        raise UsageError(f"an Ogden fit takes 1 or 2 terms, got {terms}")
    if weighting not in WEIGHTINGS:
        raise UsageError(f"unknown weighting {weighting!r}; one of {', '.join(WEIGHTINGS)}")
    keep = _before_failure(data)
    e, s = data.strain[:keep], data.stress_mpa[:keep]
    if max_strain is not None:
        e, s = e[e <= max_strain], s[e <= max_strain]
    if len(e) < _MIN_POINTS:
        below = f" up to strain {max_strain:g}" if max_strain is not None else ""
        raise UsageError(f"{data.path}: only {len(e)} points before failure{below}; a fit needs at least "
                         f"{_MIN_POINTS}")
    unconstrained = None
    if model == "ogden":
        constants = _fit_ogden(e, s, terms, weighting)
        mu0 = sum(v for k, v in constants.items() if k.startswith("mu"))
    else:
        order = 3 if model == "yeoh" else 1
        constants = _fit_yeoh(e, s, order, nonnegative, weighting)
        mu0 = 2.0 * constants["c10_mpa"]
        if nonnegative and order > 1:
            free = _fit_yeoh(e, s, order, False, weighting)
            unconstrained = free if any(v < 0 for k, v in free.items() if k != "c10_mpa") else None
    result = FitResult(model=model, constants=constants, r2=math.nan, rmse_mpa=math.nan, strain_range=None,
                       n_points=len(e), n_dropped_after_failure=len(data.strain) - keep,
                       initial_shear_modulus_mpa=float(mu0), source=data.path, max_strain=max_strain,
                       unconstrained=unconstrained, weighting=weighting,
                       fitted_strain_range=(float(e.min()), float(e.max())), n_above_max_strain=keep - len(e))
    predicted = result.stress(e)
    r2, rmse = _goodness(s, predicted)
    rng = valid_strain_range(e, s, predicted)
    log.info("%s fit of %s: R2 = %.5f over %d points", model, data.path, r2, len(e))
    return dataclasses.replace(result, r2=r2, rmse_mpa=rmse, strain_range=rng)


def fit_command(path: str | Path, model: str = "yeoh", json_path: str | Path | None = None,
                plot_path: str | Path | None = None, columns: TensileColumns | None = None,
                specimen: Specimen | None = None, *, nonnegative: bool = True,
                max_strain: float | str | None = None, weighting: str | None = None) -> FitResult:
    """``pnmold material fit``: read (:func:`read_tensile` with ``columns`` and ``specimen``), fit
    (:func:`fit_hyperelastic` with ``nonnegative``, ``max_strain`` and ``weighting``), plot and
    (optionally) write the JSON, which says what was read (``read``).

    ``max_strain``: None (the default) fits where actuators work, the points up to
    :data:`ACTUATOR_MAX_STRAIN` (all of them when the test stops earlier), weighting the relative
    error; a number fits up to that strain and ``"full"`` every point to failure, both weighting the
    stress error in MPa as pnmold always did (the library's constants were fitted so). ``weighting``
    (:data:`WEIGHTINGS`) overrides that choice.

    The plot goes to ``plot_path``, else beside the JSON (same name, ``.png``), else to
    ``out/material-fit/<stem>.png``. Both files are written atomically.
    """
    from pnmold.materials.plot import plot_fit

    data = read_tensile(path, columns, specimen)
    if max_strain is None:
        limit, weighting = ACTUATOR_MAX_STRAIN, weighting or "relative"
    else:
        limit, weighting = _max_strain(max_strain), weighting or "absolute"
    result = fit_hyperelastic(data, model, nonnegative=nonnegative, max_strain=limit, weighting=weighting)
    if plot_path is None:
        plot_path = (Path(json_path).with_suffix(".png") if json_path is not None
                     else Path("out") / "material-fit" / f"{Path(path).stem}.png")
    plot_fit(data, result, plot_path)
    result = dataclasses.replace(result, plot=str(plot_path), read=dict(data.read))
    if json_path is not None:
        write_json(json_path, result.to_json())
    return result


def _max_strain(value: float | str) -> float | None:
    """A ``--max-strain``: a number, or "full" (None: every point to failure)."""
    if isinstance(value, str) and value.strip().lower() == "full":
        return None
    try:
        limit = float(value)
    except ValueError:
        raise UsageError(f"--max-strain must be a strain (e.g. 1.5) or 'full', got {value!r}") from None
    if not math.isfinite(limit):
        raise UsageError(f"--max-strain must be a finite strain or 'full', got {value!r}")
    return limit
