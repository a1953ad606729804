"""The dataclasses of the Newton solve (:mod:`.newton`): its options, outcome and counters.

- :class:`NewtonOptions` -- tolerances, globalisation and step control;
- :class:`NewtonResult` -- the outcome of one solve (one increment);
- :class:`Stats` -- counters and timings of a whole curve.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .model import Evaluation, Stresses


@dataclass(frozen=True)
class NewtonOptions:
    """Tolerances, globalisation and step control of the nonlinear solve.

    Parameters
    ----------
    rtol : residual tolerance relative to the force scale.
    energy_rtol : or converged when the next correction would gain less than this
        fraction of the load's work so far (an error of sqrt(energy_rtol) in the energy
        norm; see :meth:`.newton.Newton._small_decrement`).
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
    ``factorizations`` those it took, ``tangents`` the tangents it used (factored or not),
    ``step_norms`` the norms of its accepted steps (mm)."""

    converged: bool
    u: np.ndarray
    evaluation: Evaluation
    residuals: list[float]
    pressure_mpa: float = 0.0
    factorizations: int = 0
    why: str = ""
    stresses: Stresses | None = None
    tangents: int = 0
    step_norms: list[float] = field(default_factory=list)


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
    contact_shortenings: int = 0
    stage_factorizations: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"assembly_s": self.assembly_s, "linear_solve_s": self.linear_solve_s,
                "corrections": self.corrections, "shifts": self.shifts,
                "factorizations": self.factorizations, "increments": self.increments,
                "residual_evaluations": self.residual_evaluations, "cuts": self.cuts,
                "newton_iterations": list(self.newton_iterations),
                "krylov_solves": self.krylov_solves, "krylov_iterations": self.krylov_iterations,
                "krylov_fallbacks": self.krylov_fallbacks,
                "contact_shortenings": self.contact_shortenings,
                "stage_factorizations": dict(self.stage_factorizations)}
