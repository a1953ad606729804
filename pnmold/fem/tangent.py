"""The linear algebra of the Newton solve (:mod:`.newton`): factor, Krylov, inertia, back-solve.

:class:`TangentSolver` assembles the tangent and factors it with the linear solver of
:mod:`.linsolve` (counting its negative eigenvalues, held at the cavity volume under volume
control, and shifting it as ``K + s diag(K)`` while it has too many: the inertia correction,
module notes 4. of :mod:`.newton`), or solves an assembled tangent by GMRES left-preconditioned
by the last factorisation (module notes 5.), and gives the Newton step ``(du, dp)`` from it,
under volume control by block elimination of the bordered system.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from .linsolve import linear_solver
from .model import Evaluation, Load, Model, Stresses
from .newton_types import NewtonOptions, Stats

log = logging.getLogger(__name__)

_ROUNDOFF = 2 * np.finfo(float).eps


class TangentSolver:
    """The linear algebra of :class:`~.newton.Newton` on a :class:`Model`'s free unknowns:
    timed evaluations, the tangent factored (its inertia counted and corrected) or solved by
    GMRES preconditioned by the last factorisation, and the Newton step from it."""

    def __init__(self, model: Model, options: NewtonOptions | None = None):
        self.model = model
        self.options = options or NewtonOptions()
        self.linear = linear_solver()
        self.stats = Stats()
        self.span = float(np.ptp(model.X, axis=0).max()) if model.X.size else 1.0
        self._floor = 0.0
        #: negative eigenvalues the tangent may have (the count at the last converged
        #: state; under volume control, of the system constrained to the cavity volume)
        self.inertia = 0
        #: the largest such count of any (unshifted) tangent of the last solve
        self.most_negatives = 0
        #: an assembled tangent that :meth:`back_solve` solves by GMRES (see :meth:`assemble`)
        self._pending = None

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

    def _moved(self, u: np.ndarray, d: np.ndarray) -> np.ndarray:
        out = u.copy()
        out[self.model.free] += d
        return out
