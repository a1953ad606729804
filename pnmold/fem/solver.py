"""Quasi-static pressure curves of a clamped actuator: free bending and blocked force.

Supports: zero displacement of every P2 node on the ``clamp`` facets; ``u_y = 0`` on the
``symmetry`` facets of a half model (``mesh.half``). Gravity (a dead load from the
density) is ramped first as its own stage, then the cavity pressure from 0 kPa with
adaptive increments (:func:`.newton.continuation`). Blocked force (supplement Fig. S6):
a rigid frictionless plane ``z = tip_z - gap`` under the tip, enforced by a penalty on the
``free_end`` nodes; the plane's total reaction is ``Step.force_n``.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..conventions import FULL_BEND_DEG
from ..errors import DesignError, SolveError
from ..tetmesh import CLAMP, SYMMETRY, TetMesh
from .material import Membrane, Yeoh
from .model import Load, Model
from .newton import Newton, NewtonOptions, continuation
from .results import Observer, Solution, Step, full_bend_pressure

log = logging.getLogger(__name__)

#: Defaults from the supplement: Elastosil M4601 (Yeoh) and the paper sheet.
ELASTOSIL_M4601 = Yeoh()
PAPER = Membrane()


@dataclass(frozen=True)
class SolveOptions:
    """Load stepping of a curve.

    Parameters
    ----------
    first_step_kpa : the first pressure increment (the stiffest-to-solve one).
    max_step_kpa : largest pressure increment.
    max_angle_step_deg : increments are shrunk so the bend angle moves at most this much.
    stop_at_full_bend : stop once the bend angle reaches 360 degrees (free bending).
    gravity_first_step : first increment of the gravity factor (0 -> 1).
    contact_stiffness_n_per_mm : penalty stiffness per node of the blocking plane.
    newton : Newton tolerances and step growth/cut control.
    """

    first_step_kpa: float = 0.25
    max_step_kpa: float = 12.0
    max_angle_step_deg: float = 40.0
    stop_at_full_bend: bool = True
    gravity_first_step: float = 0.25
    contact_stiffness_n_per_mm: float = 50.0
    newton: NewtonOptions = field(default_factory=NewtonOptions)


def _pressures(max_pressure_kpa: float | None,
               pressures_kpa: Sequence[float] | None) -> tuple[float, list[float] | None]:
    if (max_pressure_kpa is None) == (pressures_kpa is None):
        raise DesignError("pressures_kpa", "give exactly one of max_pressure_kpa, pressures_kpa")
    if pressures_kpa is not None:
        targets = sorted(float(p) for p in pressures_kpa if p > 0)
        if not targets:
            raise DesignError("pressures_kpa", "needs at least one pressure > 0")
        return targets[-1], targets
    if not max_pressure_kpa > 0:
        raise DesignError("max_pressure_kpa", f"must be > 0, got {max_pressure_kpa}")
    return float(max_pressure_kpa), None


def _clamped(mesh: TetMesh, material: Yeoh, membrane: Membrane | None, gravity: Sequence[float] | None,
             options: SolveOptions) -> tuple[Model, Newton, np.ndarray]:
    """The clamped (and, for a half model, symmetric) model, its Newton solver and the
    gravity force density (N/mm^3)."""
    fixed = {CLAMP: (0, 1, 2)}
    if mesh.half:
        fixed[SYMMETRY] = (1,)
    model = Model(mesh, material, membrane, fixed)
    gvec = np.zeros(3) if gravity is None else material.weight_density_n_per_mm3 * np.asarray(gravity, float)
    return model, Newton(model, options.newton), gvec


def _curve(mesh: TetMesh, material: Yeoh, membrane: Membrane | None, pmax: float,
           targets: list[float] | None, gravity: Sequence[float] | None,
           plane_gap_mm: float | None, options: SolveOptions) -> Solution:
    t_start = time.perf_counter()
    model, newton, gvec = _clamped(mesh, material, membrane, gravity, options)
    observer = Observer(model)
    blocked = plane_gap_mm is not None
    plane = mesh.tip_mm[2] - plane_gap_mm if blocked else None

    def load(p_kpa: float, g: float = 1.0) -> Load:
        return Load(p_kpa / 1000.0, tuple(g * gvec), plane,
                    options.contact_stiffness_n_per_mm)

    try:
        u = np.zeros(model.ndof)
        if gravity is not None and np.any(gvec):
            _, u = continuation(newton, u, lambda g: load(0.0, g), 0.0, 1.0,
                                options.gravity_first_step, 1.0, lambda *a: (False, math.inf),
                                what="gravity factor", unit="g")
        steps: list[Step] = [observer.step(0.0, u, newton.evaluate(u, load(0.0)), blocked)]
        shapes: list[np.ndarray] = [u.reshape(-1, 3)[:mesh.n_nodes].copy()]
        states: list[np.ndarray] = [u.copy()]

        def on_step(p: float, u_new: np.ndarray, ev) -> tuple[bool, float]:
            step = observer.step(p, u_new, ev, blocked)
            prev = steps[-1]
            steps.append(step)
            shapes.append(u_new.reshape(-1, 3)[:mesh.n_nodes].copy())
            states.append(u_new.copy())
            log.info("%.3g kPa: angle %.1f deg, tip (%.2f, %.2f) mm%s", p, step.bend_angle_deg,
                     step.tip_x_mm, step.tip_z_mm,
                     f", force {step.force_n:.3g} N" if blocked else "")
            dangle = abs(step.bend_angle_deg - prev.bend_angle_deg)
            limit = math.inf
            if dangle > 0 and not blocked:
                limit = (p - prev.pressure_kpa) * options.max_angle_step_deg / dangle
            stop = (options.stop_at_full_bend and not blocked
                    and step.bend_angle_deg >= FULL_BEND_DEG)
            return stop, max(limit, options.first_step_kpa / 4)

        try:
            _, u = continuation(newton, u, load, 0.0, pmax, options.first_step_kpa,
                                options.max_step_kpa, on_step, targets=targets)
        except SolveError as err:
            # keep what converged: the caller may report the curve up to the failure
            err.partial = Solution(tuple(steps), shapes[-1], None, str(err),
                                   newton.stats.as_dict(), tuple(shapes), tuple(states))
            raise
    finally:
        newton.linear.release()
    fb, reason = (None, "blocked-force curve") if blocked else full_bend_pressure(steps)
    stats = newton.stats.as_dict()
    stats.update(unknowns=int(model.free.size), tets=int(model.edofs.shape[0]),
                 total_s=time.perf_counter() - t_start)
    log.info("curve: %d unknowns, %d increments, %d factorisations, %.1f s", model.free.size,
             stats["increments"], stats["factorizations"], stats["total_s"])
    displacement = u.reshape(-1, 3)[:mesh.n_nodes].copy()
    return Solution(tuple(steps), displacement, fb, reason, stats, tuple(shapes), tuple(states))


def solve_bending(mesh: TetMesh, material: Yeoh = ELASTOSIL_M4601,
                  membrane: Membrane | None = PAPER, *, max_pressure_kpa: float | None = None,
                  pressures_kpa: Sequence[float] | None = None,
                  gravity: Sequence[float] | None = None,
                  options: SolveOptions | None = None) -> Solution:
    """Free bending of a clamped actuator under cavity pressure.

    Parameters
    ----------
    mesh : linear tets with facet sets ``cavity``, ``clamp``, ``free_end`` (and
        ``strain_limiting_layer``, ``symmetry`` for a half model).
    material : the elastomer (default Elastosil M4601, Yeoh).
    membrane : the strain-limiting sheet on ``strain_limiting_layer`` (default the paper);
        None for no sheet.
    max_pressure_kpa : solve up to this pressure, reporting every converged increment
        (stops at full bend unless ``options.stop_at_full_bend`` is False).
    pressures_kpa : or report exactly at these pressures.
    gravity : gravitational acceleration in units of g in the actuator frame, e.g.
        ``(0, 0, -1)`` chambers up; None for no gravity.
    options : load stepping and Newton options.

    Raises
    ------
    SolveError : an increment failed after the allowed cuts; names the last converged
        pressure (``last_converged``, kPa) and keeps the residual history.
    """
    pmax, targets = _pressures(max_pressure_kpa, pressures_kpa)
    return _curve(mesh, material, membrane, pmax, targets, gravity, None,
                  options or SolveOptions())


def solve_blocked_force(mesh: TetMesh, material: Yeoh = ELASTOSIL_M4601,
                        membrane: Membrane | None = PAPER, *,
                        max_pressure_kpa: float | None = None,
                        pressures_kpa: Sequence[float] | None = None, gap_mm: float = 0.0,
                        gravity: Sequence[float] | None = None,
                        options: SolveOptions | None = None) -> Solution:
    """Blocked tip force against a rigid frictionless plane ``z = tip_z - gap_mm``.

    Same parameters as :func:`solve_bending`; ``Step.force_n`` is the plane's reaction
    (N, whole actuator). Raises :class:`SolveError` like :func:`solve_bending`.
    """
    pmax, targets = _pressures(max_pressure_kpa, pressures_kpa)
    if gap_mm < 0:
        raise DesignError("gap_mm", f"must be >= 0, got {gap_mm}")
    return _curve(mesh, material, membrane, pmax, targets, gravity, float(gap_mm),
                  options or SolveOptions())


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


def blocked_force_slope(mesh: TetMesh, material: Yeoh = ELASTOSIL_M4601,
                        membrane: Membrane | None = PAPER, *, gap_mm: float = 0.0,
                        gravity: Sequence[float] | None = None,
                        options: SolveOptions | None = None) -> BlockedSlope:
    """:class:`BlockedSlope` of a clamped actuator against the plane ``z = tip_z - gap_mm``.

    The pressure's load vector at the rest state, dR/dp (follower pressure on the
    reference geometry: exact difference of two residuals), is solved with the tangent
    (contact penalty included for nodes on the plane); the reaction's change is the
    penalty on those nodes' z-motion. Raises :class:`SolveError` if gravity fails.
    """
    options = options or SolveOptions()
    if gap_mm < 0:
        raise DesignError("gap_mm", f"must be >= 0, got {gap_mm}")
    t_start = time.perf_counter()
    model, newton, gvec = _clamped(mesh, material, membrane, gravity, options)
    plane = mesh.tip_mm[2] - gap_mm
    k = options.contact_stiffness_n_per_mm

    def load(p_kpa: float, g: float = 1.0) -> Load:
        return Load(p_kpa / 1000.0, tuple(g * gvec), plane, k)

    try:
        u = np.zeros(model.ndof)
        if np.any(gvec):
            _, u = continuation(newton, u, lambda g: load(0.0, g), 0.0, 1.0, options.gravity_first_step,
                                1.0, lambda *a: (False, math.inf), what="gravity factor", unit="g")
        rest = newton.evaluate(u, load(0.0), want_k=True)
        unit = newton.evaluate(u, load(1.0))  # 1 kPa more, same geometry
        newton.linear.factor(rest.matrix)
        du = np.zeros(model.ndof)
        du[model.free] = -newton.linear.solve((unit.residual - rest.residual)[model.free])
    finally:
        newton.linear.release()
    zdofs = 3 * model.contact_nodes + 2
    gap = model.X[model.contact_nodes, 2] + u[zdofs] - plane
    closed = gap <= 0
    scale = 2.0 if mesh.half else 1.0  # a half model carries half the force
    slope = float(-k * du[zdofs][closed].sum()) * scale
    return BlockedSlope(force0_n=float(rest.contact_force_n) * scale, slope_n_per_kpa=slope,
                        unknowns=int(model.free.size), total_s=time.perf_counter() - t_start)
