"""Rank, fit, accept: which catalogued effect (if any) explains what recalibration could not.

1. The baseline (nominal model, modulus recalibrated) is fitted and judged on held-out
   blocks. If its held-out misfit is within what the noise allows and no effect gains beyond
   chance on the held-out rows (a misfit local to a few rows, e.g. the top of a ramp, is
   diluted in the pooled excess), nothing is missing.
2. Every effect that shows in the recorded kinds is fitted jointly with the calibration
   (so it is judged only by what recalibration could not absorb) and judged on the same
   held-out blocks.
3. The best is accepted only if all hold: its held-out chi-square gain over the baseline
   is far beyond chance (``DCHI2_MIN``: one fitted parameter gains ~1 on held-out data by
   chance) and removes most of the excess misfit (all of it where none is pooled); its
   parameter is plausible (inside the bounds and clearly away from the declared value); it
   wins again on most bootstrap resamples of the blocks. A parameter at the catalogue's upper
   bound is named as "at least" that value (the bounds are assumed plausible limits, and a model
   that carries an effect a little weaker than the data's pins there), and said so.
4. With one accepted, a second effect is tried on top the same way (pairs).
5. If structure is left that no effect removes, the diagnosis says "unexplained": judged on the final
   model's held-out rows against the spread of their prediction (the fold's own parameter
   uncertainty, :func:`predictive_z`), so an extrapolation is not mistaken for structure.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from pnmold.physics.characterise import LADDER_EFFECT

from .calibrate import calibration_parameters
from .fitting import Fit, Fitter, Hypothesis, Parameter

#: held-out chi-square gain needed to accept an effect (a 1-dof chi-square difference of 50
#: is a 7-sigma event by chance)
DCHI2_MIN = 50.0
#: share of the baseline's excess held-out misfit an effect must remove
EXCESS_SHARE = 0.5
#: excess held-out misfit (chi2 - n) / sqrt(2 n) above which the data are not explained
EXCESS_SIGMA = 6.0
#: share of bootstrap resamples the accepted effect must win
STABILITY = 0.7
BOOTSTRAP = 12
#: forward-difference step of :func:`jacobian`, a share of each parameter's range
JACOBIAN_STEP = 1e-3
#: the smallest value of an effect worth naming where 0.5 % of its range is too coarse: a dead volume's
#: bounds reach a piston rig's air column (500 mL), yet a 1 mL fitting counts (assumed: 0.005 of the
#: 20 mL the bounds of fittings and sensor tees were)
RESOLUTION = {"dead_volume": 0.1}
#: how far from the declared value an effect declared on (gravity: 1 g along the recording's orientation)
#: must be to be named: what a nuisance the baseline calibrates could be instead (the batch's density,
#: :data:`pnmold.diagnose.calibrate.DENSITY_WINDOW`, which the gravity hypothesis carries)
DECLARED_TOLERANCE = {"gravity": 0.1}
#: multi-start points of an effect's main parameter, as a share of its range
STARTS = (0.03, 0.15, 0.4, 0.8)
#: extra parameters fitted besides an effect's main one (the others stay at their catalogue
#: defaults: Yeoh C30 is nearly collinear with C20 on a bending curve, and the Mullins
#: exponent only shapes the reloading branch)
FIT_EXTRAS = {"viscoelasticity": ("tau_s",)}
#: start values of those extras (the misfit is flat in an effect's strength until its onset
#: or time scale is near the data's)
EXTRA_STARTS = {"viscoelasticity.tau_s": (0.3, 2.0, 12.0)}
#: a main parameter that stands in for an effect's own (``main`` of :func:`decide`): strain stiffening read off
#: the stiffening ladder by Yeoh C30 (recordings past the nominal's pressure maximum, see ``ladder_parameter``)
LADDER_KEY = LADDER_EFFECT


def ladder_parameter(top_mpa: float) -> dict[str, Parameter]:
    """``main`` for :func:`decide` when the model has a stiffening ladder up to ``top_mpa`` (else none)."""
    return {"strain_stiffening": Parameter(LADDER_KEY, 0.1 * top_mpa, 0.0, top_mpa)} if top_mpa > 0 else {}


def _effect_of(key: str) -> str | None:
    """The effect whose strength ``key`` is (its main parameter), else None (a calibration, an extra)."""
    return key if "." not in key else (key.partition(".")[0] if key == LADDER_KEY else None)


@dataclass
class Candidate:
    """One hypothesis judged on the data: full fit and held-out z-scores."""

    fit: Fit
    heldout_z: np.ndarray
    fold_x: list[np.ndarray]
    gain: float = 0.0  # held-out chi-square gain over the reference
    t_gain: float = 0.0  # paired t of that gain over blocks (evidence, not a gate: effects are local)
    excess_share: float = 0.0
    plausible: bool = True
    stability: float = 0.0
    notes: list[str] = field(default_factory=list)
    predictive_z: np.ndarray | None = None  # held-out z over the prediction's own spread (:func:`predictive_z`)
    at_bound: bool = False  # its main parameter at the upper bound: the data want at least that much

    @property
    def label(self) -> str:
        return self.fit.hypothesis.label

    @property
    def heldout_chi2(self) -> float:
        return float(np.sum(self.heldout_z ** 2))

    def uncertainty(self) -> dict[str, float]:
        """Spread (standard deviation) of each parameter over the held-out folds."""
        xs = np.array(self.fold_x)
        return {p.key: float(np.std(xs[:, i], ddof=1)) if len(xs) > 1 else float("nan")
                for i, p in enumerate(self.fit.hypothesis.parameters)}


def excess_sigma(chi2: float, n: int) -> float:
    return (chi2 - n) / np.sqrt(2.0 * max(n, 1))


def declared_value(key: str) -> float:
    """The value the rig as declared gives an effect's main parameter ``key`` (its catalogue default:
    gravity 1 g, every other term 0, its lower bound)."""
    from pnmold.effects import EFFECTS

    effect = EFFECTS.get(key)
    return effect.default if effect is not None else 0.0


def effect_parameters(effect, main: dict[str, Parameter] | None = None) -> tuple[Parameter, ...]:
    """The fitted parameters of a catalogue effect: its main one (starting from the declared value where the
    rig declares it on) and its extras (``main``: effect -> the parameter fitted instead, alone)."""
    if main and effect.name in main:
        return (main[effect.name],)
    lo, hi = effect.bounds
    declared = declared_value(effect.name)
    start = declared if lo < declared < hi else lo + 0.1 * (hi - lo)
    params = [Parameter(effect.name, start, lo, hi)]
    for extra in effect.extra:
        key, _unit, default, (elo, ehi) = extra[0], extra[1], extra[2], extra[3]
        if key not in FIT_EXTRAS.get(effect.name, ()):
            continue
        params.append(Parameter(f"{effect.name}.{key}", float(default), float(elo), float(ehi)))
    return tuple(params)


def hypothesis(effects: list, calibration: tuple[Parameter, ...] | None = None,
               main: dict[str, Parameter] | None = None) -> Hypothesis:
    """The nominal model (``calibration``: its recalibrated parameters) plus ``effects``. With ``gravity``
    the batch's density is not calibrated apart: the weight the data show is the gravity's value."""
    params = list(calibration if calibration is not None else calibration_parameters())
    if any(e.name == "gravity" for e in effects):
        params = [p for p in params if p.key != "density_scale"]
    for e in effects:
        params.extend(effect_parameters(e, main))
    return Hypothesis(tuple(e.name for e in effects), tuple(params))


def judge(fitter: Fitter, h: Hypothesis, starts: list[np.ndarray]) -> Candidate:
    full = fitter.fit(h, starts=starts)
    z, xs = fitter.heldout(h, full.x)
    full.predictions = fitter.predict(h, full.x)
    return Candidate(full, z, xs)


def starts_for(h: Hypothesis, base: dict[str, float] | None = None) -> list[np.ndarray]:
    """Multi-start points: the calibration (and any effect already fitted) from ``base`` (values by key);
    the newest effect's main parameter spread over its range (and at its declared value where that is not
    its lower bound), crossed with its extras' grids."""
    base = base or {}
    x0 = np.array([base.get(p.key, p.start) for p in h.parameters])
    grids = []
    for i, p in enumerate(h.parameters):
        if p.key in base or p.calibration:
            continue
        if _effect_of(p.key) is not None:
            declared = [p.start] if p.low < declared_value(p.key) == p.start else []
            grids.append((i, [*declared, *(p.low + share * (p.high - p.low) for share in STARTS)]))
        elif p.key in EXTRA_STARTS:
            grids.append((i, list(EXTRA_STARTS[p.key])))
    out = [x0]
    for i, values in grids:
        out = [np.where(np.arange(x.size) == i, v, x) for x in out for v in values]
    return out


def compare(cand: Candidate, ref: Candidate, blocks: np.ndarray) -> None:
    """Held-out gain of ``cand`` over ``ref``, block by block, and the share of excess removed."""
    gain = ref.heldout_z ** 2 - cand.heldout_z ** 2
    ids = np.unique(blocks)
    per_block = np.array([gain[blocks == b].sum() for b in ids])
    cand.gain = float(gain.sum())
    sd = float(np.std(per_block, ddof=1)) if per_block.size > 1 else float("inf")
    cand.t_gain = float(per_block.mean() / (sd / np.sqrt(per_block.size))) if sd > 0 else (
        float("inf") if per_block.mean() > 0 else 0.0)
    excess = ref.heldout_chi2 - ref.heldout_z.size
    # with no excess pooled (the noise allowance covers the whole; the misfit is local) an effect that gains
    # removes all there is
    cand.excess_share = float(gain.sum() / excess) if excess > 0 else float(gain.sum() > 0)


def check_plausible(cand: Candidate, effect_names: tuple[str, ...]) -> None:
    """Main parameters inside the bounds and clearly away from the declared value (an effect declared off:
    above zero, beyond twice their fold spread and the effect's resolution; one declared on, gravity: beyond
    what a calibrated nuisance could be, :data:`DECLARED_TOLERANCE`, and twice the fold spread). One at its
    upper bound stays plausible, marked ``at_bound`` and said: the data want at least that much."""
    unc = cand.uncertainty()
    for p, v in zip(cand.fit.hypothesis.parameters, cand.fit.x, strict=True):
        if p.calibration or _effect_of(p.key) not in effect_names:
            continue
        span = p.high - p.low
        declared = declared_value(p.key)
        if v >= p.high - 0.01 * span:
            cand.at_bound = True
            cand.notes.append(f"{p.key} at its upper bound {p.high:g}: the data want at least that much (the "
                              f"catalogue's bound is an assumed plausible limit)")
        elif abs(v - declared) < DECLARED_TOLERANCE.get(p.key, 0.0) + 2.0 * max(
                unc[p.key], RESOLUTION.get(p.key, 0.005 * span)):
            cand.plausible = False
            than = f"above {p.low:g}" if declared == p.low else f"other than the declared {declared:g}"
            cand.notes.append(f"{p.key} = {v:.3g} not clearly {than} (fold spread {unc[p.key]:.2g})")


def bootstrap_stability(fitter: Fitter, cands: list[Candidate], rng: np.random.Generator) -> None:
    """Share of block resamples on which each candidate has the lowest misfit."""
    blocks = fitter.data.blocks
    ids = np.unique(blocks)
    wins = np.zeros(len(cands))
    for _ in range(BOOTSTRAP):
        counts = np.bincount(rng.choice(ids.size, ids.size), minlength=ids.size)
        weight = counts[np.searchsorted(ids, blocks)].astype(float)
        chi2 = [fitter.fit(c.fit.hypothesis, weight, [c.fit.x], max_nfev=20).chi2 for c in cands]
        wins[int(np.argmin(chi2))] += 1
    for c, w in zip(cands, wins, strict=True):
        c.stability = float(w / BOOTSTRAP)


@dataclass
class Decision:
    baseline: Candidate
    ranked: list[Candidate]  # single-effect candidates, best held-out first
    accepted: list[Candidate]  # the final model's effects in order (empty: nothing missing)
    final: Candidate
    unexplained: bool


def decide(fitter: Fitter, effects: list, seed: int = 0, calibration: tuple[Parameter, ...] | None = None,
           main: dict[str, Parameter] | None = None) -> Decision:
    """The full search over ``effects`` (catalogue entries), the nominal model recalibrated with
    ``calibration`` (default: the modulus within its window); ``main``: effect -> the parameter fitted
    instead of its own (:func:`ladder_parameter`)."""
    calibration = calibration if calibration is not None else calibration_parameters()
    rng = np.random.default_rng(seed)
    blocks = fitter.data.blocks
    base = judge(fitter, hypothesis([], calibration), [np.array([p.start for p in calibration])])
    singles = [judge(fitter, h, starts_for(h, base.fit.values))
               for h in (hypothesis([e], calibration, main) for e in effects)]
    for c in singles:
        compare(c, base, blocks)
        check_plausible(c, c.fit.hypothesis.effects)
    ranked = sorted(singles, key=lambda c: c.heldout_chi2)
    accepted: list[Candidate] = []
    final = base
    if ranked and (excess_sigma(base.heldout_chi2, base.heldout_z.size) > EXCESS_SIGMA
                   or max(c.gain for c in ranked) > DCHI2_MIN):  # a local misfit the pooled excess dilutes
        bootstrap_stability(fitter, [base, *ranked[:3]], rng)
        best = ranked[0]
        if _acceptable(best):
            accepted.append(best)
            final = best
            final = _try_pairs(fitter, best, effects, blocks, calibration, main) or final
            if final is not best:
                accepted.append(final)
    final.predictive_z = predictive_z(fitter, final)
    chi2 = float(np.sum(final.predictive_z ** 2))
    unexplained = excess_sigma(chi2, final.predictive_z.size) > EXCESS_SIGMA and chi2 > 1.5 * final.predictive_z.size
    return Decision(base, ranked, accepted, final, unexplained)


def jacobian(fitter: Fitter, h: Hypothesis, x: np.ndarray) -> np.ndarray:
    """d z / d x of every row at ``x`` (forward differences, inward at a bound), (rows, parameters)."""
    z0 = fitter.z(h, x)
    cols = []
    for i, p in enumerate(h.parameters):
        step = JACOBIAN_STEP * (p.high - p.low)
        step = step if x[i] + step <= p.high else -step
        cols.append((fitter.z(h, np.where(np.arange(x.size) == i, x[i] + step, x)) - z0) / step)
    return np.column_stack(cols)


def predictive_z(fitter: Fitter, c: Candidate) -> np.ndarray:
    """Held-out z-scores against the spread of the prediction itself: each fold predicts its rows with
    parameters fitted without them, so the prediction carries their uncertainty, linearised: the
    variance J_out S J_out^T in z units, S = (J_in^T J_in + P)^-1 from the training rows' z-scores and
    a prior P of each parameter uniform over its bounds (variance range^2 / 12). A fold that
    extrapolates a parameter its training rows barely pin (the top of a single ramp and the stiffening
    that only shows there) is then not read as structure the model lacks; rows a fold's parameters do
    pin keep their plain held-out score."""
    h = c.fit.hypothesis
    folds = fitter.data.folds
    prior = np.diag([12.0 / (p.high - p.low) ** 2 for p in h.parameters])
    out = c.heldout_z.copy()
    for k, x in zip(np.unique(folds), c.fold_x, strict=True):
        train = folds != k
        jac = jacobian(fitter, h, x)
        if not np.all(np.isfinite(jac)):
            continue
        cov = np.linalg.inv(jac[train].T @ jac[train] + prior)
        var = np.einsum("ij,jk,ik->i", jac[~train], cov, jac[~train])
        out[~train] = c.heldout_z[~train] / np.sqrt(1.0 + var)
    return out


def _acceptable(c: Candidate) -> bool:
    ok = c.gain > DCHI2_MIN and c.excess_share > EXCESS_SHARE and c.plausible and c.stability >= STABILITY
    if not ok:
        c.notes.append(f"not accepted: held-out chi-square gain {c.gain:.0f} (needs > {DCHI2_MIN:.0f}), removes "
                       f"{100 * c.excess_share:.0f}% of the excess misfit (needs > {100 * EXCESS_SHARE:.0f}%), "
                       f"wins {100 * c.stability:.0f}% of resamples (needs {100 * STABILITY:.0f}%)"
                       + ("" if c.plausible else ", implausible parameter"))
    return ok


def _try_pairs(fitter: Fitter, first: Candidate, effects: list, blocks: np.ndarray,
               calibration: tuple[Parameter, ...], main: dict[str, Parameter] | None) -> Candidate | None:
    """A second effect on top of ``first``, accepted by the same rules against ``first``."""
    if excess_sigma(first.heldout_chi2, first.heldout_z.size) <= EXCESS_SIGMA:
        return None
    named = first.fit.hypothesis.effects
    best = None
    for e in effects:
        if e.name in named:
            continue
        h = hypothesis([*[x for x in effects if x.name in named], e], calibration, main)
        c = judge(fitter, h, starts_for(h, first.fit.values))
        compare(c, first, blocks)
        check_plausible(c, h.effects)
        if best is None or c.heldout_chi2 < best.heldout_chi2:
            best = c
    if best is not None and best.gain > DCHI2_MIN and best.excess_share > EXCESS_SHARE and best.plausible:
        return best
    return None
