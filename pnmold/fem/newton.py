"""Newton's method with a guarded line search, and adaptive load stepping.

Why these choices (measured on fPN bodies, see the FEM module notes): thin walls of a
nearly incompressible elastomer, bonded to a nearly inextensible sheet, rotate a lot at
small pressures. An additive Newton step linearises those rotations, so the trial state
carries spurious volume change and sheet stretch ~ (rotation)^2 x (a huge modulus): the
residual spikes after a good step and the next iteration removes the spike. An energy or
slope line search reads the spike as "too long a step" and crawls, so the line search
here is a *guard*: the full step is taken unless it inverts an element (then alpha is
halved) or, from iteration ``line_search_from`` on, the slope of the potential along
the step ``g(alpha) = d . R(u + alpha d)`` shows the step overshoots a minimum by far
(then secant steps on g, Crisfield's line search on the energy using residuals only).

Load stepping: increments start at ``first`` and are scaled by ``target_iterations /
iterations`` (within [0.5, growth]); failed ones are halved (or shrunk to the allowed
first correction). The first increment of a stage starts from the equilibrium tangent
(the load of the last converged state, an Euler predictor), later ones from an
extrapolation of the last converged states (:func:`_predict`). More than ``max_cuts`` consecutive
cuts raise :class:`SolveError` with the last converged load and the residual history.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import SolveError
from .linsolve import linear_solver
from .model import Evaluation, Load, Model

log = logging.getLogger(__name__)

#: The residual cannot drop below (stiffness) x (round-off of coordinates): with the
#: paper's E*t = 650 N/mm that floor is ~1e-10 N, above rtol * load at small loads.
_ROUNDOFF = 2 * np.finfo(float).eps


@dataclass(frozen=True)
class NewtonOptions:
    """Tolerances, globalisation and step control of the nonlinear solve.

    ``reuse_below``: from the third iteration, when the residual has fallen by this
    factor or more since the previous one, the last factorisation is reused (a modified
    Newton step: one back-substitution instead of a refactorisation). On the 5-chamber
    fig-s2c-w2 curve with gravity it cut factorisations from 215 to 161 and the solve
    time by 28%; 0 turns it off.
    """

    rtol: float = 1e-6
    max_iterations: int = 14
    diverge_after: int = 6
    target_iterations: int = 5
    growth: float = 2.0
    max_cuts: int = 10
    max_correction: float = 0.05
    line_search_from: int = 2
    line_search_eta: float = 0.8
    max_line_search: int = 5
    predictor_order: int = 4
    reuse_below: float = 0.2  # modified Newton once the residual falls 5x per iteration


@dataclass
class NewtonResult:
    """Outcome of one Newton solve; ``oversize`` > 1 when rejected for a too large step."""

    converged: bool
    u: np.ndarray
    evaluation: Evaluation
    residuals: list[float]
    oversize: float = 0.0


@dataclass
class Stats:
    """Counters and timings of one solve, in seconds."""

    assembly_s: float = 0.0
    linear_solve_s: float = 0.0
    factorizations: int = 0
    residual_evaluations: int = 0
    increments: int = 0
    cuts: int = 0
    newton_iterations: list[int] = field(default_factory=list)
    reused_solves: int = 0

    def as_dict(self) -> dict:
        return {"assembly_s": self.assembly_s, "linear_solve_s": self.linear_solve_s,
                "reused_solves": self.reused_solves,
                "factorizations": self.factorizations, "increments": self.increments,
                "residual_evaluations": self.residual_evaluations, "cuts": self.cuts,
                "newton_iterations": list(self.newton_iterations)}


class Newton:
    """Solves R(u; load) = 0 for the free unknowns of a :class:`Model`."""

    def __init__(self, model: Model, options: NewtonOptions | None = None):
        self.model = model
        self.options = options or NewtonOptions()
        self.linear = linear_solver()
        self.stats = Stats()
        self._span = float(np.ptp(model.X, axis=0).max()) if model.X.size else 1.0
        self._floor = 0.0

    def evaluate(self, u: np.ndarray, load: Load, want_k: bool = False) -> Evaluation:
        """Timed :meth:`Model.evaluate`."""
        t = time.perf_counter()
        ev = self.model.evaluate(u, load, want_k)
        self.stats.assembly_s += time.perf_counter() - t
        self.stats.residual_evaluations += not want_k
        return ev

    def _tolerance(self, ev: Evaluation) -> float:
        reaction = float(np.linalg.norm(ev.residual[self.model.fixed]))
        return max(self.options.rtol * max(ev.external_norm, reaction), self._floor)

    def _direction(self, u: np.ndarray, load: Load, r: np.ndarray) -> np.ndarray:
        kev = self.evaluate(u, load, want_k=True)
        self._floor = (_ROUNDOFF * self._span
                       * float(np.linalg.norm(kev.matrix.data[self.model.diag_pos])))
        t = time.perf_counter()
        self.linear.factor(kev.matrix)
        d = -self.linear.solve(r)
        self.stats.linear_solve_s += time.perf_counter() - t
        self.stats.factorizations += 1
        return d

    def _reuse(self, r: np.ndarray) -> np.ndarray:
        """A modified-Newton correction with the current factorisation (no refactoring)."""
        t = time.perf_counter()
        d = -self.linear.solve(r)
        self.stats.linear_solve_s += time.perf_counter() - t
        self.stats.reused_solves += 1
        return d

    def solve(self, u0: np.ndarray, load: Load, tangent_load: Load | None = None
              ) -> NewtonResult:
        """Newton from ``u0`` at ``load``.

        ``tangent_load`` (the load of the converged state ``u0``) gives the first
        iteration the equilibrium tangent. Gives up early when the first correction
        exceeds ``max_correction`` x the body's size (``oversize`` says by how much) or
        when the residual has not fallen over two iterations after ``diverge_after``.
        """
        m, opt = self.model, self.options
        u = u0.copy()
        ev = self.evaluate(u, load)
        history: list[float] = []
        if not ev.ok:
            return NewtonResult(False, u, ev, [float("inf")])
        for it in range(opt.max_iterations + 1):
            r = ev.residual[m.free]
            rn = float(np.linalg.norm(r))
            history.append(rn)
            if rn <= self._tolerance(ev):
                log.debug("converged: residuals %s", " ".join(f"{h:.1e}" for h in history))
                self.stats.newton_iterations.append(it)
                return NewtonResult(True, u, ev, history)
            # diverging: no progress over the last two iterations. Not "above the starting
            # residual": after a tiny increment that one is tiny, the first correction's
            # spurious rotation spike is not, and a converging solve would be cut forever.
            if (it == opt.max_iterations or not np.isfinite(rn) or rn > 1e8 * history[0]
                    or (it >= opt.diverge_after and rn > history[-3])):
                break
            if it >= 2 and opt.reuse_below > 0 and rn < opt.reuse_below * history[-2]:
                d = self._reuse(r)  # converging fast: the last factorisation still serves
            else:
                d = self._direction(u, tangent_load if it == 0 and tangent_load else load, r)
            if it == 0:
                oversize = float(np.max(np.abs(d))) / (opt.max_correction * self._span)
                if oversize > 1.0:
                    log.debug("  first correction %.3g x the allowed size", oversize)
                    return NewtonResult(False, u, ev, history, oversize)
            u_new, ev_new, alpha = self._line_search(u, d, r, load, it >= opt.line_search_from)
            if ev_new is None:
                history.append(float("inf"))
                break
            log.debug("  it %d: |r| %.3e, |d| %.3e, alpha %.3g, negative pivots %d", it, rn,
                      float(np.max(np.abs(d))), alpha, self.linear.negative_pivots)
            u, ev = u_new, ev_new
        return NewtonResult(False, u, ev, history)

    def _line_search(self, u: np.ndarray, d: np.ndarray, r0: np.ndarray, load: Load,
                     slope: bool) -> tuple[np.ndarray, Evaluation | None, float]:
        """Full step unless it inverts elements or (``slope``) overshoots a minimum."""
        m, opt = self.model, self.options
        g0 = float(d @ r0)
        alpha, best = 1.0, None
        for _ in range(opt.max_line_search + 3):
            trial = u.copy()
            trial[m.free] += alpha * d
            ev = self.evaluate(trial, load)
            if not ev.ok:
                if best is not None:
                    break
                alpha *= 0.5
                continue
            best = (trial, ev, alpha)
            if not slope or g0 >= 0:
                break
            g = float(d @ ev.residual[m.free])
            if g <= 0 or abs(g) <= opt.line_search_eta * abs(g0) or alpha < 0.05:
                break
            alpha *= min(max(g0 / (g0 - g), 0.2), 0.9)
        if best is None:
            return u, None, 0.0
        return best


def _predict(history: list[tuple[float, np.ndarray]], t_new: float, order: int
             ) -> np.ndarray:
    """Lagrange extrapolation of the last ``order + 1`` converged states to ``t_new``.

    On an fPN body from 0 to 5 kPa (41k unknowns) orders 1/2/3/4 needed 134/95/72/57
    factorisations: points move on arcs as the actuator curls, and a higher-order
    prediction leaves a smaller spurious volume change for Newton to remove.
    """
    pts = history[-(order + 1):]
    out = np.zeros_like(pts[-1][1])
    for i, (ti, ui) in enumerate(pts):
        w = 1.0
        for j, (tj, _) in enumerate(pts):
            if j != i:
                w *= (t_new - tj) / (ti - tj)
        out += w * ui
    return out


def continuation(newton: Newton, u: np.ndarray, load_at: Callable[[float], Load],
                 t0: float, t1: float, first: float, max_step: float,
                 on_step: Callable[[float, np.ndarray, Evaluation], tuple[bool, float]],
                 targets: Sequence[float] | None = None, what: str = "pressure",
                 unit: str = "kPa") -> tuple[float, np.ndarray]:
    """March ``t`` from ``t0`` (``u`` converged there) to ``t1``.

    ``on_step(t, u, ev)`` -> (stop, largest next increment). Returns the last converged
    ``(t, u)``. With ``targets``, increments land on each target exactly and ``on_step``
    is called only there.
    """
    opt, stats = newton.options, newton.stats
    t, dt, cuts, limit = t0, first, 0, max_step
    history = [(t0, u)]
    eps = 1e-12 * max(1.0, abs(t1))
    stops = sorted(set(targets or ()) | {t1})
    while t < t1 - eps:
        nxt = next(s for s in stops if s > t + eps)
        dt = min(dt, limit, max_step)
        t_new = nxt if nxt - (t + dt) < 0.1 * dt else t + dt
        if len(history) > 1:
            res = newton.solve(_predict(history, t_new, opt.predictor_order), load_at(t_new))
            if not res.converged and res.oversize == 0.0:  # the predictor may overshoot
                res = newton.solve(u, load_at(t_new), tangent_load=load_at(t))
        else:
            res = newton.solve(u, load_at(t_new), tangent_load=load_at(t))
        if not res.converged:
            if t_new - t < 1e-3 * first:
                raise SolveError(
                    f"{what} increment to {t_new:.4g} {unit} stalled below {1e-3 * first:.3g} {unit}; "
                    f"last converged {what} {t:.4g} {unit}", last_converged=t, residuals=res.residuals)
            cuts += 1
            stats.cuts += 1
            log.info("%s %.4g %s: Newton failed (residuals %s); cutting the step", what,
                     t_new, unit, ", ".join(f"{h:.2e}" for h in res.residuals[-4:]))
            if cuts > opt.max_cuts:
                raise SolveError(
                    f"{what} increment to {t_new:.4g} {unit} failed after {cuts - 1} cuts; "
                    f"last converged {what} {t:.4g} {unit}", last_converged=t,
                    residuals=res.residuals)
            shrink = 0.5 if res.oversize <= 1.0 else min(0.5, 0.8 / res.oversize)
            dt = (t_new - t) * shrink
            continue
        stats.increments += 1
        its = max(stats.newton_iterations[-1], 1)
        log.debug("%s %.4g %s converged in %d iterations", what, t_new, unit, its)
        step, t, u, cuts = t_new - t, t_new, res.u, 0
        history = (history + [(t, u)])[-(opt.predictor_order + 1):]
        dt = step * min(max(opt.target_iterations / its, 0.5), opt.growth)
        if targets is None or any(abs(t - s) <= eps for s in stops):
            stop, limit = on_step(t, u, res.evaluation)
            if stop:
                break
    return t, u
