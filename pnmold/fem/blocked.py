"""The blocked tip force to first order in pressure (:func:`blocked_force_slope`).

Linearised about the unpressurised actuator resting on the blocking plane of
:func:`~.solver.solve_blocked_force` (gravity applied): one factorisation and one solve after
the gravity stage instead of a nonlinear curve.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import DesignError
from ..tetmesh import TetMesh
from .linsolve import one_blas_thread
from .material import Membrane, Yeoh
from .path import PathFailure
from .solver import ELASTOSIL_M4601, PAPER, SolveOptions, _Setup


@dataclass(frozen=True)
class BlockedSlope:
    """The blocked tip force to first order in pressure: ``force0_n + slope_n_per_kpa * p``.

    Linearised about the unpressurised state resting on the plane (gravity applied): one
    extra factorisation and one solve after the gravity stage, instead of a nonlinear curve
    that costs minutes (the tip pins while the middle arches). Tests compare it with
    :func:`solve_blocked_force` where both run.
    """

    force0_n: float
    slope_n_per_kpa: float
    unknowns: int
    total_s: float

    def force_n(self, pressure_kpa: float) -> float:
        return self.force0_n + self.slope_n_per_kpa * float(pressure_kpa)


def _without_krylov(options: SolveOptions) -> SolveOptions:
    """``options`` factoring every tangent: against the plane, a later Newton iterate's tangent
    differs from the increment's first by the contact penalty of the nodes that touched down
    since, which the first tangent's factorisation does not precondition (GMRES ran its 30
    products and was factored after all). Measured on the fPN's build mesh with gravity:
    the rest state on the plane in 10.2 s with GMRES, 6.0 s without, the slope the same to 2e-7."""
    return dataclasses.replace(options, newton=dataclasses.replace(options.newton, krylov_iterations=0))


@one_blas_thread
def blocked_force_slope(mesh: TetMesh, material: Yeoh = ELASTOSIL_M4601,
                        membrane: Membrane | None = PAPER, *, gap_mm: float = 0.0,
                        gravity: Sequence[float] | None = None,
                        options: SolveOptions | None = None,
                        regions: Mapping[str, Yeoh] | None = None) -> BlockedSlope:
    """:class:`BlockedSlope` of a clamped actuator against the plane ``z = tip_z - gap_mm``.

    The pressure's load vector at the rest state, dR/dp (follower pressure on the
    reference geometry: exact difference of two residuals), is solved with the tangent
    (contact penalty included for nodes on the plane); the reaction's change is the
    penalty on those nodes' z-motion. Raises :class:`SolveError` if gravity fails.
    """
    options = _without_krylov(options or SolveOptions())
    if gap_mm < 0:
        raise DesignError("gap_mm", f"must be >= 0, got {gap_mm}")
    t_start = time.perf_counter()
    plane = mesh.tip_mm[2] - gap_mm
    setup = _Setup(mesh, material, membrane, gravity, plane, options, regions)
    model, newton = setup.model, setup.newton
    k = options.contact_stiffness_n_per_mm
    try:
        try:
            u = setup.gravity(setup.rest()).u
        except PathFailure as fail:
            raise setup.error("gravity", fail, f"{fail.last.t:.4g} g of {fail.target:.4g} g "
                              "(the actuator resting on the blocking plane)", None, 0.0) from None
        rest = newton.factor(u, setup.load(0.0))
        unit = newton.evaluate(u, setup.load(0.001))  # 1 kPa more, same geometry
        du = np.zeros(model.ndof)
        du[model.free] = -newton.back_solve((unit.residual - rest.residual)[model.free])
    finally:
        newton.linear.release()
    zdofs = 3 * model.contact_nodes + 2
    gap = model.X[model.contact_nodes, 2] + u[zdofs] - plane
    closed = gap <= 0
    scale = 2.0 if mesh.half else 1.0  # a half model carries half the force
    slope = float(-k * du[zdofs][closed].sum()) * scale
    return BlockedSlope(force0_n=float(rest.contact_force_n) * scale, slope_n_per_kpa=slope,
                        unknowns=int(model.free.size), total_s=time.perf_counter() - t_start)
