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

What makes this body hard, measured on the fPN (issue 17): thin rubber walls and soft
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
   wander, the negative pivot coming and going (the Ecoflex 00-30 stalls of issue 17). Such
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
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np

from .linsolve import linear_solver
from .model import Evaluation, Load, Model, Stresses

log = logging.getLogger(__name__)

_ROUNDOFF = 2 * np.finfo(float).eps


@dataclass(frozen=True)
class NewtonOptions:
    """Tolerances, globalisation and step control of the nonlinear solve.

    Parameters
    ----------
    rtol : residual tolerance relative to the force scale.
    energy_rtol : or converged when the next correction would gain less than this
        fraction of the load's work so far (an error of sqrt(energy_rtol) in the energy
        norm; see :meth:`Newton._small_decrement`).
    volume_rtol : cavity-volume tolerance relative to the prescribed volume.
    max_iterations : Newton iterations per increment (14: near a limit point, e.g. the sPN's
        pressure maximum or the end of the Fig. S2A 5 mm member's curve, the last
        increments need 8-12; with 7 they were cut until the curve failed).
    diverge_after : from this iteration on, give up when two iterations made no progress.
    target_iterations : tangents per increment (Newton iterations, factored or solved by GMRES,
        and inertia shifts) the step control aims at.
    growth : largest factor between consecutive increments.
    max_cuts : halvings of a failed increment before the solve gives up.
    max_correction : a Newton step moving a node more than this fraction of the body's
        size is scaled down before the line search (a trust region against wild steps).
    armijo : sufficient decrease of the merit along the step.
    max_line_search : merit evaluations per line search after the correction.
    predictor_order : order of the extrapolation of converged states.
    mixed : build the tangent with the mixed-integration-point stresses (see the module
        notes); False for the plain Newton tangent.
    inertia_shifts : when an iterate's tangent has more negative eigenvalues than the last
        converged state's, it is refactored as ``K + s diag(K)`` with these ``s`` in turn until
        it has not (inertia correction, module notes 4.); () to never shift.
    krylov_iterations : GMRES iterations allowed to solve a later iteration's tangent with the
        increment's factorisation as preconditioner (module notes, 5.); 0 to factor every
        tangent.
    krylov_rtol : GMRES's tolerance on the preconditioned residual, relative to its start (on
        the fPN 1e-3 added Newton iterations, 1e-5 products, for no fewer factorisations).
        The convergence test's correction is solved to it too: at 1e-1 it saved about 2 s of
        the fPN's 25, but near a critical point the tangent is nearly singular and a loose
        solve misjudges the energy left, so a state off the path passed as converged (an
        Ecoflex 00-30 fPN hanging chambers down then failed at 4.873 kPa where 1e-4 names its
        pressure maximum at 4.862 kPa, ``benchmarks/fe_robust.py`` seed 2, design 21).
    """

    rtol: float = 1e-6
    energy_rtol: float = 1e-7
    volume_rtol: float = 1e-7
    max_iterations: int = 14
    diverge_after: int = 8
    target_iterations: int = 3
    growth: float = 2.0
    max_cuts: int = 8
    max_correction: float = 0.25
    armijo: float = 1e-4
    max_line_search: int = 6
    predictor_order: int = 4
    mixed: bool = True
    inertia_shifts: tuple[float, ...] = (1e-4, 1e-3, 1e-2)
    krylov_iterations: int = 30
    krylov_rtol: float = 1e-4


@dataclass
class NewtonResult:
    """Outcome of one Newton solve. ``pressure_mpa`` is the solved pressure under volume
    control (the given one under load control); ``why`` says why it failed;
    ``factorizations`` those it took, ``tangents`` the tangents it used (factored or not)."""

    converged: bool
    u: np.ndarray
    evaluation: Evaluation
    residuals: list[float]
    pressure_mpa: float = 0.0
    factorizations: int = 0
    why: str = ""
    stresses: Stresses | None = None
    tangents: int = 0


@dataclass
class Stats:
    """Counters and timings of one curve, in seconds."""

    assembly_s: float = 0.0
    linear_solve_s: float = 0.0
    factorizations: int = 0
    residual_evaluations: int = 0
    increments: int = 0
    cuts: int = 0
    newton_iterations: list[int] = field(default_factory=list)
    corrections: int = 0
    shifts: int = 0
    krylov_solves: int = 0
    krylov_iterations: int = 0
    krylov_fallbacks: int = 0
    stage_factorizations: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"assembly_s": self.assembly_s, "linear_solve_s": self.linear_solve_s,
                "corrections": self.corrections, "shifts": self.shifts,
                "factorizations": self.factorizations, "increments": self.increments,
                "residual_evaluations": self.residual_evaluations, "cuts": self.cuts,
                "newton_iterations": list(self.newton_iterations),
                "krylov_solves": self.krylov_solves, "krylov_iterations": self.krylov_iterations,
                "krylov_fallbacks": self.krylov_fallbacks,
                "stage_factorizations": dict(self.stage_factorizations)}


@dataclass
class _Point:
    """A state on the line search: displacement, pressure, evaluation and merit."""

    u: np.ndarray
    p: float
    ev: Evaluation
    merit: float
    how: str = ""
    alpha: float = 1.0


class Newton:
    """Solves R(u; load) = 0 for the free unknowns of a :class:`Model`."""

    def __init__(self, model: Model, options: NewtonOptions | None = None):
        self.model = model
        self.options = options or NewtonOptions()
        self.linear = linear_solver()
        self.stats = Stats()
        self.span = float(np.ptp(model.X, axis=0).max()) if model.X.size else 1.0
        self._floor = 0.0
        self._rho = 0.0
        #: a force (norm, N) below which the residual need not go relative to ``rtol``:
        #: the solver sets it to the full weight, so that the first small increments of a
        #: ramp are converged as well as the last, not 100 times better
        self.reference_force = 0.0
        #: negative eigenvalues the tangent may have (the count at the last converged
        #: state; under volume control, of the system constrained to the cavity volume)
        self.inertia = 0
        #: the same count of the first tangent of the last solve (at its predicted state)
        self.first_negatives = 0
        #: the largest such count of any (unshifted) tangent of the last solve
        self.most_negatives = 0
        #: tetrahedra that inverted at a trial state of the last solve (for diagnostics)
        self.inverted = np.zeros(0, np.int64)
        #: an assembled tangent that :meth:`back_solve` solves by GMRES (see :meth:`assemble`)
        self._pending = None

    # -- building blocks ----------------------------------------------------------------
    def evaluate(self, u: np.ndarray, load: Load, want_k: bool = False) -> Evaluation:
        """Timed :meth:`Model.evaluate`."""
        t = time.perf_counter()
        ev = self.model.evaluate(u, load, want_k)
        self.stats.assembly_s += time.perf_counter() - t
        self.stats.residual_evaluations += not want_k
        return ev

    def factor(self, u: np.ndarray, load: Load, mixed: Stresses | None = None) -> Evaluation:
        """Assemble and factor the tangent at ``u`` (its stress terms from ``mixed`` if
        given); returns the evaluation there."""
        ev = self.assemble(u, load, mixed)
        self._factor(ev.matrix)
        self._pending = None
        if mixed is None:  # a tangent at a converged state sets the inertia to expect
            self.inertia = self.linear.negative_pivots
        return ev

    def assemble(self, u: np.ndarray, load: Load, mixed: Stresses | None = None) -> Evaluation:
        """Assemble the tangent at ``u`` without factoring it: until the next :meth:`factor`,
        :meth:`back_solve` solves with it by GMRES, preconditioned by the last factorisation."""
        t = time.perf_counter()
        ev = self.model.evaluate(u, load, True, mixed)
        self.stats.assembly_s += time.perf_counter() - t
        self._floor = (_ROUNDOFF * self.span
                       * float(np.linalg.norm(ev.matrix.data[self.model.diag_pos])))
        self._pending = ev.matrix
        return ev

    def _krylov(self, rhs: np.ndarray, g: np.ndarray | None = None, c: float = 0.0
                ) -> tuple[np.ndarray, float, np.ndarray | None] | None:
        """Solve with the assembled, unfactored tangent ``K`` (:meth:`assemble`) by GMRES,
        left-preconditioned by the last factorisation ``M`` (the preconditioned residual is
        then nearly the error of the solution; it must fall to ``krylov_rtol`` of the start's
        within ``krylov_iterations``, else None): ``K x = rhs``, or with ``g`` the bordered
        system of volume control ``K x - y g = rhs, g . x = c``, preconditioned by the same
        system with ``M`` (block elimination, ``M^-1 g`` once). Returns ``(x, y, M^-1 g)``
        (``y = 0`` and no ``M^-1 g`` without ``g``)."""
        from scipy.sparse.linalg import LinearOperator, gmres

        upper, solve = self._pending, self.linear.solve
        diag = upper.diagonal()
        count = [0]

        def k_times(x: np.ndarray) -> np.ndarray:
            count[0] += 1
            return upper @ x + upper.T @ x - diag * x

        if g is None:
            def apply(z: np.ndarray) -> np.ndarray:
                return solve(k_times(z))
            start, n, mg, scale = solve(rhs), rhs.size, None, 1.0
        else:
            mg, mr = solve(np.column_stack([g, rhs])).T  # one call for both: ~1.1x one solve
            gmg = float(g @ mg)
            # the unknown y enters as the displacement it causes, y |M^-1 g|: one unit (mm)
            # for both parts of the preconditioned residual
            scale = float(np.linalg.norm(mg)) or 1.0

            def bordered(mx: np.ndarray, cx: float) -> np.ndarray:
                """``[M, -g; g^T, 0]^-1 [x; cx]`` from ``mx = M^-1 x``, scaled."""
                y = (cx - float(g @ mx)) / gmg
                return np.append(mx + y * mg, y * scale)

            def apply(z: np.ndarray) -> np.ndarray:
                x, y = z[:-1], z[-1] / scale
                return bordered(solve(k_times(x) - y * g), float(g @ x))
            start, n = bordered(mr, c), rhs.size + 1
        z, info = gmres(LinearOperator((n, n), matvec=apply, dtype=float), start, x0=start,
                        rtol=self.options.krylov_rtol, restart=self.options.krylov_iterations,
                        maxiter=1)
        self.stats.krylov_solves += 1
        self.stats.krylov_iterations += count[0]
        log.debug("    GMRES: %d products%s", count[0], "" if info == 0 else ", not converged")
        if info != 0:
            return None
        return (z, 0.0, None) if g is None else (z[:-1], z[-1] / scale, mg)

    def _factor_pending(self, g: np.ndarray | None = None) -> None:
        """Factor the assembled tangent after all (GMRES did not converge with the old one, or
        a failed solve needs its inertia); its negative eigenvalues (held at the cavity volume
        with ``g``) count toward :attr:`most_negatives`."""
        self.stats.krylov_fallbacks += 1
        self._factor(self._pending)
        self._pending = None
        self.most_negatives = max(self.most_negatives, self.negatives(g))

    def _factor(self, matrix) -> None:
        t = time.perf_counter()
        self.linear.factor(matrix)
        self.stats.linear_solve_s += time.perf_counter() - t
        self.stats.factorizations += 1

    def _correct_inertia(self, ev: Evaluation, constraint: np.ndarray | None, negatives: int) -> int:
        """Refactor ``K + s diag(K)`` while the tangent (``negatives`` negative eigenvalues) has
        more than the last converged state (module notes, 4.); returns the factorisations it took."""
        extra, n = 0, 0
        if self.inertia < 0 or negatives <= self.inertia:
            return 0
        diag = ev.matrix.data[self.model.diag_pos].copy()
        for shift in self.options.inertia_shifts:
            shifted = ev.matrix.copy()
            shifted.data[self.model.diag_pos] = diag + shift * np.abs(diag)
            self._factor(shifted)
            n += 1
            extra = self.negatives(constraint) - self.inertia
            log.debug("    inertia correction: shift %.0e, %d negative eigenvalues too many", shift, extra)
            if extra <= 0:
                break
        self.stats.shifts += n
        return n

    def negatives(self, g: np.ndarray | None = None) -> int:
        """Negative eigenvalues of the last factored tangent; with ``g`` (the cavity volume's
        gradient, free unknowns) those of the tangent constrained to a fixed volume: one
        fewer when ``g . K^-1 g < 0`` (Haynsworth's inertia of the bordered matrix: past a
        pressure maximum K has one negative pivot that the syringe's constraint removes).
        -1 when the linear solver gives no inertia."""
        neg = self.linear.negative_pivots
        if neg <= 0 or g is None:  # a positive definite K has g . K^-1 g > 0: no solve needed
            return neg
        return neg - int(float(g @ self.back_solve(g)) < 0.0)

    def back_solve(self, rhs: np.ndarray, exact: bool = True) -> np.ndarray:
        """``K^-1 rhs`` (free unknowns) for the last tangent: with its factorisation, or for an
        assembled one (:meth:`assemble`) by GMRES; ``exact=False``: with the last
        factorisation even then (an estimate, as a modified Newton step)."""
        t = time.perf_counter()
        if self._pending is not None and exact and rhs.ndim == 2:
            self._factor_pending()  # GMRES takes one right-hand side
        if self._pending is not None and exact:
            out = self._krylov(rhs)
            if out is not None:
                self.stats.linear_solve_s += time.perf_counter() - t
                return out[0]
            self._factor_pending()
        x = self.linear.solve(rhs)
        self.stats.linear_solve_s += time.perf_counter() - t
        return x

    def tolerance(self, ev: Evaluation) -> float:
        """Residual tolerance at ``ev``: rtol x force scale, above the round-off floor."""
        reaction = float(np.linalg.norm(ev.residual[self.model.fixed]))
        scale = max(ev.external_norm, reaction, self.reference_force)
        return max(self.options.rtol * scale, self._floor)

    def _merit(self, ev: Evaluation, p: float, volume: float | None) -> float:
        if volume is None or not ev.ok:
            return ev.energy
        c = ev.cavity_volume_mm3 - volume
        return ev.energy + p * volume + 0.5 * self._rho * c * c

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
        history: list[float] = []
        n_fact, short, guarded, unshifted = 0, 0, False, self.inertia
        fact0, reusable = self.stats.factorizations, False
        self.most_negatives = 0
        self._rho = 0.0
        self._pending = None  # a tangent left by the last solve is not this one's
        self.inverted = ev.inverted if not ev.ok else np.zeros(0, np.int64)

        constraint = None

        def result(ok: bool, why: str = "") -> NewtonResult:
            if not ok and self._pending is not None:
                # the last tangent was solved by GMRES: factor it for its inertia, which
                # tells the step control a critical point from a Newton failure
                self._factor_pending(constraint)
            if ok:
                # the unshifted tangent's count: a shifted one would hide a lost stability
                self.inertia = unshifted if n_fact else self.inertia
                self.stats.newton_iterations.append(len(history) - 1)
                log.debug("converged: residuals %s", " ".join(f"{h:.1e}" for h in history))
            return NewtonResult(ok, u, ev, history, p, self.stats.factorizations - fact0, why,
                                m.stresses(u) if ok else None, n_fact)

        if not ev.ok:
            history.append(float("inf"))
            return result(False, "the starting state inverts elements")
        volume_tol = opt.volume_rtol * abs(volume) if volume is not None else 0.0
        constraint = ev.volume_gradient[m.free] if volume is not None else None
        for it in range(opt.max_iterations + 1):
            rn = float(np.linalg.norm(ev.residual[m.free]))
            history.append(rn)
            c = ev.cavity_volume_mm3 - volume if volume is not None else 0.0
            if rn <= self.tolerance(ev) and abs(c) <= volume_tol and (it > 0 or self._floor > 0):
                return result(True)
            if not np.isfinite(rn) or rn > 1e8 * max(history[0], 1e-300):
                return result(False, "the residual diverged")
            if it == opt.max_iterations:
                break
            if it >= opt.diverge_after and rn > min(history[-3], history[-2]):
                return result(False, "no progress")
            step = None
            if reusable and opt.krylov_iterations > 0:  # the last factorisation preconditions
                n_fact += 1
                self.assemble(u, replace(load, pressure_mpa=p), mixed)
                step = self._step(u, p, ev, volume, load, guarded, reused=True)
                if step is None:
                    log.debug("  no step with the reused factorisation: factoring the tangent")
            if step is None:
                n_fact += 1
                tangent = self.factor(u, replace(load, pressure_mpa=p), mixed)
                negatives = unshifted = self.negatives(constraint)
                self.most_negatives = max(self.most_negatives, negatives)
                if it == 0:
                    self.first_negatives = negatives
                    if strict and self.first_negatives > self.inertia >= 0:
                        return result(False, f"the tangent at the predicted state has "
                                      f"{self.first_negatives} negative eigenvalues (at the last "
                                      f"state {self.inertia}): the step is too long")
                shifts = self._correct_inertia(tangent, constraint, negatives)
                n_fact += shifts
                reusable = shifts == 0 and (self.inertia < 0 or negatives <= self.inertia)
                step = self._step(u, p, ev, volume, load, guarded)
            log.debug("  it %d: |r| %.3e -> %s", it, rn, "rejected" if step is None else
                      f"{np.linalg.norm(step.ev.residual[m.free]):.3e} ({step.how})")
            if step is None:
                return result(False, "no descent: the line search found no acceptable step")
            if mixed is not None:
                mixed = self._update_stresses(u, step, mixed)
            u, p, ev = step.u, step.p, step.ev
            short = short + 1 if step.alpha < 0.3 else 0
            if short >= 2 and not guarded:
                # crawling: the energy reads a spurious stretch as an overlong step
                # (module notes, 3.); from here on full steps, guarded against inversion
                log.debug("  the line search keeps shortening the step: full steps from here")
                guarded = True
            polished = self._small_decrement(u, p, ev, volume, load, work, volume_tol) if work > 0 else None
            if polished is not None:
                u, p, ev = polished
                history.append(float(np.linalg.norm(ev.residual[m.free])))
                return result(True)
        return result(False, f"not converged in {opt.max_iterations} iterations")

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

    def _direction(self, ev: Evaluation, volume: float | None, exact: bool = True
                   ) -> tuple[np.ndarray, float, np.ndarray | None]:
        """Newton step ``(du, dp, a)`` from the current tangent (``a = K^-1 g``; after GMRES its
        estimate with the last factorisation); ``exact=False``: from the last factorisation
        (see :meth:`back_solve`)."""
        m = self.model
        if volume is not None and exact and self._pending is not None:
            t = time.perf_counter()
            out = self._krylov(-ev.residual[m.free], ev.volume_gradient[m.free],
                               volume - ev.cavity_volume_mm3)
            self.stats.linear_solve_s += time.perf_counter() - t
            if out is not None:
                return out
            self._factor_pending(ev.volume_gradient[m.free])
        r = ev.residual[m.free]
        if volume is None:
            return -self.back_solve(r, exact), 0.0, None
        g = ev.volume_gradient[m.free]
        rg = self.back_solve(np.column_stack([r, g]), exact)  # one call: ~1.1x one solve
        b, a = -rg[:, 0], rg[:, 1]
        dp = -(ev.cavity_volume_mm3 - volume + float(g @ b)) / float(g @ a)
        return b + dp * a, dp, a

    def _step(self, u: np.ndarray, p: float, ev: Evaluation, volume: float | None,
              load: Load, guarded: bool = False, reused: bool = False) -> _Point | None:
        """Direction, then merit line search with a second-order correction; ``guarded``:
        the full step unless it inverts elements (then halved); ``reused`` (the tangent solved
        by GMRES, its inertia unknown): None at once when the step is no descent direction."""
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

        def at(x: np.ndarray, pp: float, alpha: float, how: str) -> _Point:
            e = self.evaluate(x, replace(load, pressure_mpa=pp))
            if not e.ok:
                self.inverted = e.inverted  # the last (smallest) step that inverted
            return _Point(x, pp, e, self._merit(e, pp, volume) if e.ok else np.inf, how, alpha)

        def accept(pt: _Point) -> bool:
            """Sufficient decrease of the merit, or of the residual (Newton's own
            measure, which also holds where the merit is only nearly the potential)."""
            if not pt.ev.ok:
                return False
            if pt.merit <= merit0 + opt.armijo * pt.alpha * slope + noise:
                return True
            cv = abs(pt.ev.cavity_volume_mm3 - volume) if volume is not None else 0.0
            return (float(np.linalg.norm(pt.ev.residual[m.free])) <= 0.5 * rn0
                    and cv <= max(0.5 * c0, c_tol))

        alpha = min(1.0, opt.max_correction * self.span / big) if big > 0 else 1.0
        trial = at(self._moved(u, alpha * d), p_new, alpha, "full step")
        if slope >= 0 and reused:
            return None
        if slope >= 0 or guarded:  # not a descent direction, or crawling: guarded steps
            for _ in range(opt.max_line_search):
                if trial.ev.ok:
                    return trial
                alpha *= 0.5
                trial = at(self._moved(u, alpha * d), p_new, alpha, f"guarded x{alpha:.3g}")
            return None
        if accept(trial):
            return trial
        if trial.ev.ok:  # second-order correction with the same factorisation
            d2, dp2, _ = self._direction(trial.ev, volume)
            if float(np.max(np.abs(d2))) <= alpha * big:  # a correction, not a new step
                self.stats.corrections += 1
                corrected = at(self._moved(trial.u, d2), p_new + dp2, alpha, "corrected")
                if accept(corrected):
                    return corrected
        best = trial if trial.ev.ok else None
        for _ in range(opt.max_line_search):
            if trial.ev.ok:  # minimiser of the parabola through merit(0), slope, merit(alpha)
                denom = trial.merit - merit0 - slope * alpha
                guess = -slope * alpha * alpha / (2.0 * denom) if denom > 0 else 0.5 * alpha
                alpha = min(max(guess, 0.1 * alpha), 0.5 * alpha)
            else:
                alpha *= 0.25
            trial = at(self._moved(u, alpha * d), p_new, alpha, f"alpha {alpha:.3g}")
            if accept(trial):
                return trial
            if trial.ev.ok and (best is None or trial.merit < best.merit):
                best = trial
        return best if best is not None and best.merit < merit0 else None

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

    def _moved(self, u: np.ndarray, d: np.ndarray) -> np.ndarray:
        out = u.copy()
        out[self.model.free] += d
        return out
