"""Newton's method under load control or cavity-volume control, globalised on the energy.

The load is conservative (cavity pressure is ``p dV``, gravity a dead load, contact a
penalty), so a potential ``Pi(u) = W(u) - p V(u) - f_g . u + W_contact`` exists and the
tangent is symmetric. Each iteration factors the tangent (PARDISO) and searches along the
step on a merit function:

- load control (``volume=None``): ``Pi(u)`` itself;
- volume control (the cavity volume ``V*`` prescribed, the pressure an unknown, as a
  syringe pump drives the supplement's P-V test): the bordered system
  ``K du - g dp = -R, g . du = V* - V`` (``g = dV/du``), solved by block elimination with
  one factorisation and two back-substitutions; the merit is the augmented Lagrangian
  ``Pi(u; p_new) + p_new V* + rho/2 (V - V*)^2``, ``rho`` large enough for descent.

What makes this body hard, measured on the fPN: thin rubber walls and soft
chamber hinges bonded to a nearly inextensible sheet give the tangent eigenvalues from
~1e-5 (the body's own bending, a chamber rocking on its floor) to ~1e3 (the sheet's
E*t); an additive step linearises rotations, so a predicted or corrected state carries a
spurious stretch (sheet) and volume change (mean dilatation) ~ rotation^2 times those
stiff moduli. Three consequences and their treatment here:

1. The tangent at a predicted state is polluted by those spurious stresses (on the fPN,
   hundreds of negative pivots at an extrapolated state). The *mixed-integration-point*
   Newton (Magisano, Leonetti & Garcea, CMAME 313:986, 2017) builds the tangent's stress
   terms -- the element pressures of the mean dilatation and the sheet's stress -- from
   independent stresses: predicted with the displacements, then updated by the
   Hellinger-Reissner linearisation ``s + alpha (S(u) + C:B d - s)`` after each step.
   The energy and residual are never changed, so the converged solution is the
   displacement solution. On the fPN 0 -> 20 kPa it cut the factorisations from 426
   to 99 (same converged curve).
2. The residual norm is dominated by the sheet: a correction of 0.01 mm along the soft
   bending leaves a residual of the order of the tolerance in the sheet alone. Besides
   the residual test (``rtol`` times the force scale, above the round-off floor of the
   stiffest part), an increment is converged in the *energy norm* when the next
   correction, estimated with the current factorisation, would gain less than
   ``energy_rtol`` of the load's work so far.
3. The spurious stretch raises the energy after a good step (the Maratos effect of
   constrained optimisation), so a plain backtracking search crawls. Before shortening
   a rejected step it is corrected with the residual at the trial state and the same
   factorisation (a *second-order correction*, Nocedal & Wright, Numerical
   Optimization, section 15.6), accepted only if it is a correction (no longer than the
   step). A step is also accepted when it halves the residual (Newton's own measure).

4. Near a stable state an iterate's tangent may still have a negative eigenvalue (a thin
   wall or a channel's roof over one element, a soft rubber's floppy mode): the Newton step
   is then no descent direction of the energy, the line search fails and the iterates
   wander, the negative pivot coming and going (the Ecoflex 00-30 stalls this handles). Such
   a tangent is refactored as ``K + s diag(K)`` with ``s`` from ``inertia_shifts`` until its
   inertia is the converged state's (the inertia correction of interior-point methods,
   Nocedal & Wright, section 19.3; Waechter & Biegler, Math. Prog. 106:25, 2006): a
   descent direction, and where the iterates reach a state whose own tangent has the
   expected inertia, plain Newton again. Counted under the cavity-volume constraint. A
   converged state's own count is its last *unshifted* tangent's: a shift must never hide
   that the path lost stability (the step control then ends the stage as an instability).

5. A factorisation costs about 14 back-substitutions here (fPN build mesh: 0.35 s and
   25 ms). Within an increment the tangent changes little from one iterate to the next,
   so only an increment's first tangent (at the predicted state, where its inertia is
   checked) is factored; the later iterations assemble theirs and solve with it by GMRES
   left-preconditioned by that factorisation (``krylov_rtol``: an inexact Newton step,
   Dembo, Eisenstat & Steihaug, SIAM J. Numer. Anal. 19:400, 1982); under volume control
   on the bordered system, preconditioned by the same block elimination. 3-8 products per
   step; where GMRES does not converge in ``krylov_iterations``, or its step is no descent
   direction (its inertia is unknown), the tangent is factored after all, with the
   inertia checks above. The energy-norm test and the second-order correction's estimates
   use the factorisation as it is (a modified Newton step). On the fPN this halved the
   factorisations of the curve (107 -> 50) at the same time and the same curve (full-bend
   pressure 47.5985 -> 47.6000 kPa).

When the search has shortened the step twice in a row (crawling), the rest of the
increment takes full steps guarded only against inverted elements: where the spurious
stretch dominates the energy, the next Newton iteration removes it, as the plain guarded
Newton this module replaced did. An increment fails fast (the caller then shortens
it): when the tangent at the predicted state has more negative pivots than the last
converged state's (the predictor went too far; ``strict``), when there is no progress
after ``diverge_after`` iterations, or after ``max_iterations``.

The solve is split along its seams: :mod:`.newton_types` holds the options, the result and
the counters; :mod:`.tangent` the linear algebra (factorisation, GMRES, inertia, back-solves,
the Newton step); :mod:`.linesearch` the merit line search along the step; this module the
iteration itself (convergence tests, reuse of a factorisation, the energy-norm test).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np

from .linesearch import LineSearch, _Point
from .model import Evaluation, Load, Model, Stresses
from .newton_types import NewtonOptions, NewtonResult, Stats

__all__ = ["Newton", "NewtonOptions", "NewtonResult", "Stats"]

log = logging.getLogger(__name__)


@dataclass
class _Run:
    """The state of one :meth:`Newton.solve` carried from one iteration to the next."""

    u: np.ndarray
    p: float
    ev: Evaluation
    mixed: Stresses | None  # the mixed stresses of the next tangent (None: plain Newton)
    history: list[float] = field(default_factory=list)  # residual norms
    step_norms: list[float] = field(default_factory=list)  # the accepted steps' norms (mm)
    constraint: np.ndarray | None = None  # the cavity volume's gradient under volume control
    n_fact: int = 0  # tangents used: factored, shifted or solved by GMRES
    short: int = 0  # line searches in a row that cut the step below 0.3
    guarded: bool = False  # crawling: full steps guarded against inversion from here on
    unshifted: int = 0  # negative eigenvalues of the last unshifted factored tangent
    fact0: int = 0  # factorisations counted before this solve
    reusable: bool = False  # the last factorisation may precondition the next tangent


class Newton(LineSearch):
    """Solves R(u; load) = 0 for the free unknowns of a :class:`Model`."""

    def __init__(self, model: Model, options: NewtonOptions | None = None):
        super().__init__(model, options)
        #: a force (norm, N) below which the residual need not go relative to ``rtol``:
        #: the solver sets it to the full weight, so that the first small increments of a
        #: ramp are converged as well as the last, not 100 times better
        self.reference_force = 0.0
        #: negative eigenvalues (counted as :attr:`inertia`) of the first tangent of the last
        #: solve (at its predicted state)
        self.first_negatives = 0

    def tolerance(self, ev: Evaluation) -> float:
        """Residual tolerance at ``ev``: rtol x force scale, above the round-off floor."""
        reaction = float(np.linalg.norm(ev.residual[self.model.fixed]))
        scale = max(ev.external_norm, reaction, self.reference_force)
        return max(self.options.rtol * scale, self._floor)

    # -- the solve ----------------------------------------------------------------------
    def solve(self, u0: np.ndarray, load: Load, tangent_load: Load | None = None,
              volume: float | None = None, stresses: Stresses | None = None,
              work: float = 0.0, strict: bool = False) -> NewtonResult:
        """Newton from ``u0`` at ``load``.

        With ``volume`` (mm^3, the whole model's cavity as meshed) the cavity volume is
        prescribed and ``load.pressure_mpa`` is only the starting pressure: the result's
        ``pressure_mpa`` is the pressure that holds it. ``stresses`` are the predicted
        stresses of the first tangent (mixed Newton; default: those at ``u0``). ``work``
        (N mm, the load's work so far) enables the energy-norm convergence test.
        ``strict``: give up at once when the first tangent has more negative pivots than
        the last converged state's (the predictor went too far; a retry with a shorter
        increment passes ``strict=False``, as the path may really cross an instability).
        ``tangent_load`` is accepted for compatibility and ignored.
        """
        del tangent_load
        m, opt = self.model, self.options
        mixed = (stresses or m.stresses(u0)) if opt.mixed else None
        p, u = load.pressure_mpa, u0.copy()
        ev = self.evaluate(u, load)
        run = _Run(u, p, ev, mixed, unshifted=self.inertia, fact0=self.stats.factorizations)
        self.most_negatives = 0
        self._rho = 0.0
        self._pending = None  # a tangent left by the last solve is not this one's
        self.inverted = ev.inverted if not ev.ok else np.zeros(0, np.int64)
        if not ev.ok:
            run.history.append(float("inf"))
            return self._result(run, False, "the starting state inverts elements")
        volume_tol = opt.volume_rtol * abs(volume) if volume is not None else 0.0
        run.constraint = ev.volume_gradient[m.free] if volume is not None else None
        for it in range(opt.max_iterations + 1):
            rn = float(np.linalg.norm(run.ev.residual[m.free]))
            run.history.append(rn)
            c = run.ev.cavity_volume_mm3 - volume if volume is not None else 0.0
            if rn <= self.tolerance(run.ev) and abs(c) <= volume_tol and (it > 0 or self._floor > 0):
                return self._result(run, True)
            if not np.isfinite(rn) or rn > 1e8 * max(run.history[0], 1e-300):
                return self._result(run, False, "the residual diverged")
            if it == opt.max_iterations:
                break
            if it >= opt.diverge_after and rn > min(run.history[-3], run.history[-2]):
                return self._result(run, False, "no progress")
            why = self._iterate(run, it, load, volume, strict)
            if why:
                return self._result(run, False, why)
            if work > 0 and self._polish(run, volume, load, work, volume_tol):
                return self._result(run, True)
        return self._result(run, False, f"not converged in {opt.max_iterations} iterations")

    def _iterate(self, run: _Run, it: int, load: Load, volume: float | None, strict: bool) -> str:
        """Iteration ``it``: a step with the reused factorisation (GMRES) or a factored tangent,
        then the state moved along it; returns why the solve fails there, else ''."""
        step = self._reused_step(run, load, volume)
        if step is None:
            step, why = self._factored_step(run, it, load, volume, strict)
            if why:
                return why
        log.debug("  it %d: |r| %.3e -> %s", it, run.history[-1], "rejected" if step is None else
                  f"{np.linalg.norm(step.ev.residual[self.model.free]):.3e} ({step.how})")
        if step is None:
            return "no descent: the line search found no acceptable step"
        self._advance(run, step)
        return ""

    def _reused_step(self, run: _Run, load: Load, volume: float | None) -> _Point | None:
        """The step with the tangent assembled and solved by GMRES, preconditioned by the last
        factorisation (module notes, 5.), where that may be reused; else None."""
        if not (run.reusable and self.options.krylov_iterations > 0):
            return None
        run.n_fact += 1
        self.assemble(run.u, replace(load, pressure_mpa=run.p), run.mixed)
        step = self._step(run.u, run.p, run.ev, volume, load, run.guarded, reused=True)
        if step is None:
            log.debug("  no step with the reused factorisation: factoring the tangent")
        return step

    def _factored_step(self, run: _Run, it: int, load: Load, volume: float | None, strict: bool
                       ) -> tuple[_Point | None, str]:
        """The step with the tangent factored, its inertia counted and corrected (module notes,
        4.); ``(None, why)`` when ``strict`` and the first tangent is less stable than the last
        converged state's."""
        run.n_fact += 1
        tangent = self.factor(run.u, replace(load, pressure_mpa=run.p), run.mixed)
        negatives = run.unshifted = self.negatives(run.constraint)
        self.most_negatives = max(self.most_negatives, negatives)
        if it == 0:
            self.first_negatives = negatives
            if strict and self.first_negatives > self.inertia >= 0:
                return None, (f"the tangent at the predicted state has {self.first_negatives} negative "
                              f"eigenvalues (at the last state {self.inertia}): the step is too long")
        shifts = self._correct_inertia(tangent, run.constraint, negatives)
        run.n_fact += shifts
        run.reusable = shifts == 0 and (self.inertia < 0 or negatives <= self.inertia)
        return self._step(run.u, run.p, run.ev, volume, load, run.guarded), ""

    def _advance(self, run: _Run, step: _Point) -> None:
        """Move to the accepted ``step``: the mixed stresses updated along it, and the
        search guarded once it crawls."""
        if run.mixed is not None:
            run.mixed = self._update_stresses(run.u, step, run.mixed)
        run.step_norms.append(float(np.linalg.norm(step.u - run.u)))
        run.u, run.p, run.ev = step.u, step.p, step.ev
        run.short = run.short + 1 if step.alpha < 0.3 else 0
        if run.short >= 2 and not run.guarded:
            # crawling: the energy reads a spurious stretch as an overlong step
            # (module notes, 3.); from here on full steps, guarded against inversion
            log.debug("  the line search keeps shortening the step: full steps from here")
            run.guarded = True

    def _polish(self, run: _Run, volume: float | None, load: Load, work: float,
                volume_tol: float) -> bool:
        """Whether the state is converged in the energy norm (:meth:`_small_decrement`); then
        ``run`` holds the polished state."""
        polished = self._small_decrement(run.u, run.p, run.ev, volume, load, work, volume_tol)
        if polished is None:
            return False
        run.u, run.p, run.ev = polished
        run.history.append(float(np.linalg.norm(run.ev.residual[self.model.free])))
        return True

    def _result(self, run: _Run, ok: bool, why: str = "") -> NewtonResult:
        """The outcome of the solve in the state ``run`` (counters and inertia updated)."""
        if not ok and self._pending is not None:
            # the last tangent was solved by GMRES: factor it for its inertia, which
            # tells the step control a critical point from a Newton failure
            self._factor_pending(run.constraint)
        if ok:
            # the unshifted tangent's count: a shifted one would hide a lost stability
            self.inertia = run.unshifted if run.n_fact else self.inertia
            self.stats.newton_iterations.append(len(run.history) - 1)
            log.debug("converged: residuals %s", " ".join(f"{h:.1e}" for h in run.history))
        return NewtonResult(ok, run.u, run.ev, run.history, run.p, self.stats.factorizations - run.fact0,
                            why, self.model.stresses(run.u) if ok else None, run.n_fact, run.step_norms)

    def _small_decrement(self, u: np.ndarray, p: float, ev: Evaluation, volume: float | None,
                         load: Load, work: float, volume_tol: float
                         ) -> tuple[np.ndarray, float, Evaluation] | None:
        """Converged in the energy norm (module notes, 2.): the next correction, estimated
        with the current factorisation (one back-substitution), would gain less than
        ``energy_rtol`` of the work the load has done so far. Then up to three such
        corrections are taken (one residual evaluation each, while the residual falls,
        until it meets ``rtol``) and the state returned; else None."""
        m, opt = self.model, self.options
        if volume is not None and abs(ev.cavity_volume_mm3 - volume) > volume_tol:
            return None
        d, dp, _ = self._direction(ev, volume)
        r = ev.residual[m.free]
        if volume is not None:
            r = r - dp * ev.volume_gradient[m.free]
        decrement = abs(float(d @ r))
        log.debug("    decrement %.2e of the work %.2e, next correction %.3g mm",
                  decrement, work, float(np.max(np.abs(d))))
        if decrement > opt.energy_rtol * work:
            return None
        for _ in range(3):  # polish with the same factorisation (modified Newton)
            u2 = self._moved(u, d)
            ev2 = self.evaluate(u2, replace(load, pressure_mpa=p + dp))
            if not ev2.ok or (np.linalg.norm(ev2.residual[m.free])
                              >= np.linalg.norm(ev.residual[m.free])):
                break
            u, p, ev = u2, p + dp, ev2
            if np.linalg.norm(ev.residual[m.free]) <= self.tolerance(ev):
                break
            d, dp, _ = self._direction(ev, volume, exact=False)
        return u, p, ev

    def _update_stresses(self, u: np.ndarray, step: _Point, mixed: Stresses) -> Stresses:
        """The mixed stresses after a step of ``alpha`` times the Newton step: the Hellinger-
        Reissner update ``s + alpha (S(u) + C:B d - s)``, i.e. the stresses linearised along
        the step taken, less ``(1 - alpha)`` of the gap between ``S(u)`` and ``s``. A full
        step gives ``S(u) + C:B d``; a short one keeps the predicted stresses, instead of
        the spurious ones of a poorly predicted ``u``."""
        m = self.model
        along = m.stresses(u, step.u - u)
        if step.alpha >= 1.0:
            return along
        here = m.stresses(u)
        keep = 1.0 - step.alpha
        return along.combine([1.0, -keep, keep], [along, here, mixed])
