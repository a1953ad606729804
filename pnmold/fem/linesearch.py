"""The globalisation of the Newton solve (:mod:`.newton`): a merit line search along the step.

:class:`LineSearch` takes the Newton step of :class:`~.tangent.TangentSolver` and searches
along it on a merit function (the potential under load control, an augmented Lagrangian
under volume control): the full step, then a second-order correction with the same
factorisation, then a backtracking on the parabola through the merit; or, where the step is
no descent direction or the search crawls, full steps guarded only against inverted
elements (module notes 3. of :mod:`.newton`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from .model import Evaluation, Load, Model
from .newton_types import NewtonOptions
from .tangent import TangentSolver

log = logging.getLogger(__name__)


@dataclass
class _Point:
    """A state on the line search: displacement, pressure, evaluation and merit."""

    u: np.ndarray
    p: float
    ev: Evaluation
    merit: float
    how: str = ""
    alpha: float = 1.0


@dataclass(frozen=True)
class _Search:
    """The start of one line search: the step ``(d, dp)`` to the pressure ``p_new``, the merit
    and its slope along the step there, and what a trial must beat to be accepted."""

    load: Load
    volume: float | None
    d: np.ndarray
    p_new: float
    merit0: float
    slope: float
    rn0: float
    c0: float
    c_tol: float
    noise: float
    big: float


class LineSearch(TangentSolver):
    """:class:`~.tangent.TangentSolver` with the merit line search along its Newton step."""

    def __init__(self, model: Model, options: NewtonOptions | None = None):
        super().__init__(model, options)
        self._rho = 0.0
        #: tetrahedra that inverted at a trial state of the last solve (for diagnostics)
        self.inverted = np.zeros(0, np.int64)

    def _merit(self, ev: Evaluation, p: float, volume: float | None) -> float:
        if volume is None or not ev.ok:
            return ev.energy
        c = ev.cavity_volume_mm3 - volume
        return ev.energy + p * volume + 0.5 * self._rho * c * c

    def _step(self, u: np.ndarray, p: float, ev: Evaluation, volume: float | None,
              load: Load, guarded: bool = False, reused: bool = False) -> _Point | None:
        """Direction, then merit line search with a second-order correction; ``guarded``:
        the full step unless it inverts elements (then halved); ``reused`` (the tangent solved
        by GMRES, its inertia unknown): None at once when the step is no descent direction."""
        search = self._search(p, ev, volume, load)
        big = search.big
        alpha = min(1.0, self.options.max_correction * self.span / big) if big > 0 else 1.0
        trial = self._at(search, self._moved(u, alpha * search.d), search.p_new, alpha, "full step")
        if search.slope >= 0 and reused:
            return None
        if search.slope >= 0 or guarded:  # not a descent direction, or crawling: guarded steps
            return self._guarded(search, u, trial, alpha)
        if self._accept(search, trial):
            return trial
        if trial.ev.ok:  # second-order correction with the same factorisation
            corrected = self._second_order(search, trial, alpha)
            if corrected is not None:
                return corrected
        return self._backtrack(search, u, trial, alpha)

    def _search(self, p: float, ev: Evaluation, volume: float | None, load: Load) -> _Search:
        """The Newton step at ``ev`` and the merit and its slope along it (under volume
        control the penalty ``rho`` raised until the step is a descent direction)."""
        m, opt = self.model, self.options
        d, dp, a = self._direction(ev, volume)
        p_new = p + dp
        r0 = ev.residual[m.free]
        merit0 = ev.energy  # Pi is affine in p: Pi(u; p_new) = Pi(u; p) - dp V(u)
        slope, c0, c_tol = float(d @ r0), 0.0, 0.0
        if volume is not None:
            g = ev.volume_gradient[m.free]
            r0 = r0 - dp * g  # the residual at u under the new pressure
            c = ev.cavity_volume_mm3 - volume
            c0, c_tol = abs(c), opt.volume_rtol * abs(volume)
            ga = abs(float(g @ a))
            self._rho = max(self._rho, 2.0 / ga)
            slope = float(d @ r0) - self._rho * c * c
            while slope >= 0 and self._rho < 1e12 / ga:
                self._rho *= 10.0
                slope = float(d @ r0) - self._rho * c * c
            merit0 += -dp * ev.cavity_volume_mm3 + p_new * volume + 0.5 * self._rho * c * c
        rn0 = float(np.linalg.norm(r0))
        noise = 1e-11 * (abs(merit0) + 1.0)
        big = float(np.max(np.abs(d))) if d.size else 0.0
        if log.isEnabledFor(logging.DEBUG):
            where = m.X[m.free[int(np.argmax(np.abs(d)))] // 3]
            log.debug("    direction: max |d| %.3g mm at (%.1f, %.1f, %.1f), negative pivots %d",
                      big, *where, self.linear.negative_pivots)
        return _Search(load, volume, d, p_new, merit0, slope, rn0, c0, c_tol, noise, big)

    def _at(self, search: _Search, x: np.ndarray, pp: float, alpha: float, how: str) -> _Point:
        """The trial state ``x`` at the pressure ``pp``, evaluated, with its merit."""
        e = self.evaluate(x, replace(search.load, pressure_mpa=pp))
        if not e.ok:
            self.inverted = e.inverted  # the last (smallest) step that inverted
        return _Point(x, pp, e, self._merit(e, pp, search.volume) if e.ok else np.inf, how, alpha)

    def _accept(self, search: _Search, pt: _Point) -> bool:
        """Sufficient decrease of the merit, or of the residual (Newton's own
        measure, which also holds where the merit is only nearly the potential)."""
        if not pt.ev.ok:
            return False
        if pt.merit <= search.merit0 + self.options.armijo * pt.alpha * search.slope + search.noise:
            return True
        volume = search.volume
        cv = abs(pt.ev.cavity_volume_mm3 - volume) if volume is not None else 0.0
        return (float(np.linalg.norm(pt.ev.residual[self.model.free])) <= 0.5 * search.rn0
                and cv <= max(0.5 * search.c0, search.c_tol))

    def _guarded(self, search: _Search, u: np.ndarray, trial: _Point, alpha: float) -> _Point | None:
        """The full step, halved while it inverts elements (no merit test)."""
        for _ in range(self.options.max_line_search):
            if trial.ev.ok:
                return trial
            alpha *= 0.5
            trial = self._at(search, self._moved(u, alpha * search.d), search.p_new, alpha,
                             f"guarded x{alpha:.3g}")
        return None

    def _second_order(self, search: _Search, trial: _Point, alpha: float) -> _Point | None:
        """The rejected ``trial`` corrected with its own residual and the same factorisation
        (module notes 3. of :mod:`.newton`), if that is a correction and accepted; else None."""
        d2, dp2, _ = self._direction(trial.ev, search.volume)
        if float(np.max(np.abs(d2))) <= alpha * search.big:  # a correction, not a new step
            self.stats.corrections += 1
            corrected = self._at(search, self._moved(trial.u, d2), search.p_new + dp2, alpha,
                                 "corrected")
            if self._accept(search, corrected):
                return corrected
        return None

    def _backtrack(self, search: _Search, u: np.ndarray, trial: _Point, alpha: float
                   ) -> _Point | None:
        """Shorter steps from the rejected ``trial``: the first accepted, else the best one that
        lowers the merit, else None."""
        merit0, slope = search.merit0, search.slope
        best = trial if trial.ev.ok else None
        for _ in range(self.options.max_line_search):
            if trial.ev.ok:  # minimiser of the parabola through merit(0), slope, merit(alpha)
                denom = trial.merit - merit0 - slope * alpha
                guess = -slope * alpha * alpha / (2.0 * denom) if denom > 0 else 0.5 * alpha
                alpha = min(max(guess, 0.1 * alpha), 0.5 * alpha)
            else:
                alpha *= 0.25
            trial = self._at(search, self._moved(u, alpha * search.d), search.p_new, alpha,
                             f"alpha {alpha:.3g}")
            if self._accept(search, trial):
                return trial
            if trial.ev.ok and (best is None or trial.merit < best.merit):
                best = trial
        return best if best is not None and best.merit < merit0 else None
