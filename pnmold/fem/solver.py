"""Quasi-static pressure curves of a clamped actuator: free bending and blocked force.

Supports: zero displacement of every P2 node on the ``clamp`` facets; ``u_y = 0`` on the
``symmetry`` facets of a half model (``mesh.half``). Gravity (a dead load from the
density) is ramped first as its own stage by load control, then the cavity is inflated
by volume control from 0 kPa (:mod:`.path`): the curve ends at full bend, at the pressure
limit, at a pressure maximum (reported, not a failure) or where the largest principal
stretch passes the material's stretch at break. Blocked force (supplement Fig. S6): a
rigid frictionless plane ``z = tip_z - gap`` under the tip, enforced by a penalty on the
``free_end`` nodes; the plane's total reaction is ``Step.force_n``.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NoReturn

import numpy as np

from ..conventions import FULL_BEND_DEG
from ..errors import DesignError, SolveError
from ..tetmesh import CLAMP, SYMMETRY, TetMesh
from . import failure
from .contact import SelfContact
from .linsolve import one_blas_thread
from .material import Membrane, Yeoh
from .model import Load, Model
from .newton import Newton, NewtonOptions
from .path import Control, PathFailure, State, inflate, ramp
from .results import Observer, PressureMaximum, Solution, Step, full_bend_pressure

log = logging.getLogger(__name__)

#: Defaults from the supplement: Elastosil M4601 (Yeoh) and the paper sheet.
ELASTOSIL_M4601 = Yeoh()
PAPER = Membrane()


@dataclass(frozen=True)
class SolveOptions:
    """Load stepping of a curve.

    Parameters
    ----------
    first_step_kpa : the first pressure increment; None: the one whose tangent
        prediction bends ``first_angle_step_deg``.
    max_step_kpa : largest pressure increment.
    max_angle_step_deg : increments are shrunk so the bend angle moves at most this much.
    first_angle_step_deg : bend of the first increment of each stage (from its tangent).
    stop_at_full_bend : stop once the bend angle reaches 360 degrees (free bending).
    past_pressure_maximum : keep inflating past a pressure maximum (a syringe's curve,
        the pressure then falls) instead of ending the curve there.
    max_stretch : end the curve once the largest principal stretch exceeds this (e.g.
        1 + the elongation at break); None: the material's ``stretch_at_break``.
    gravity_first_step : first increment of the gravity factor (0 -> 1); None: from
        the tangent.
    contact_stiffness_n_per_mm : penalty stiffness per node of the blocking plane.
    self_contact : the outer surface's frictionless self-contact (:mod:`.contact`: walls that
        meet across a gap, the tip meeting the base); None (the default): none, the body may
        pass through itself.
    newton : Newton tolerances and step growth/cut control.
    """

    first_step_kpa: float | None = None
    max_step_kpa: float = 12.0
    max_angle_step_deg: float = 40.0
    first_angle_step_deg: float = 8.0
    stop_at_full_bend: bool = True
    past_pressure_maximum: bool = False
    max_stretch: float | None = None
    gravity_first_step: float | None = None
    contact_stiffness_n_per_mm: float = 50.0
    self_contact: SelfContact | None = None
    newton: NewtonOptions = field(default_factory=NewtonOptions)

    def control(self) -> Control:
        return Control(first_angle_deg=self.first_angle_step_deg,
                       max_angle_deg=self.max_angle_step_deg,
                       max_pressure_step_mpa=self.max_step_kpa / 1000.0)


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


class _Setup:
    """The clamped (and, for a half model, symmetric) model, its Newton solver, its
    observer and the loads of one curve."""

    def __init__(self, mesh: TetMesh, material: Yeoh, membrane: Membrane | None,
                 gravity: Sequence[float] | None, plane_z_mm: float | None,
                 options: SolveOptions, regions: Mapping[str, Yeoh] | None):
        fixed = {CLAMP: (0, 1, 2)}
        if mesh.half:
            fixed[SYMMETRY] = (1,)
        self.model = Model(mesh, material, membrane, fixed, regions=regions, self_contact=options.self_contact)
        self.newton = Newton(self.model, options.newton)
        self.observer = Observer(self.model)
        self.options = options
        self.plane = plane_z_mm
        self.gvec = (np.zeros(3) if gravity is None
                     else material.weight_density_n_per_mm3 * np.asarray(gravity, float))
        weight = self.model.gravity_vector(self.gvec)[self.model.free]
        self.newton.reference_force = float(np.linalg.norm(weight))

    def load(self, p_mpa: float, g: float = 1.0) -> Load:
        return Load(p_mpa, tuple(g * self.gvec), self.plane,
                    self.options.contact_stiffness_n_per_mm)

    def angle(self, u: np.ndarray) -> float:
        """Unwrapped bend angle (degrees), tracked along the path."""
        return math.degrees(self.observer.bend_angle(u))

    def rest(self) -> State:
        u = np.zeros(self.model.ndof)
        return State(0.0, u, 0.0, self.newton.evaluate(u, self.load(0.0, 0.0)))

    def gravity(self, start: State) -> State:
        """Ramp the weight from 0 to 1 g (load control); logs each increment."""
        if not np.any(self.gvec):
            return start
        opt = self.options
        n0 = self.newton.stats.factorizations
        control = Control(first_angle_deg=opt.first_angle_step_deg,
                          max_angle_deg=opt.max_angle_step_deg)
        try:
            end = ramp(self.newton, start, lambda g: self.load(0.0, g), 1.0, self.angle,
                       lambda s: (False, 0.0), control, what="gravity", unit="g",
                       first_step=opt.gravity_first_step)
        finally:
            self.newton.stats.stage_factorizations["gravity"] = self.newton.stats.factorizations - n0
        return State(0.0, end.u, 0.0, end.ev, end.stresses)

    def error(self, stage: str, fail: PathFailure, unit_load: str,
              partial: Solution | None, last: float | None) -> SolveError:
        res = fail.result
        region = failure.locate(self.model, res.u if res else fail.last.u,
                                res.evaluation.residual if res and res.evaluation.ok else None,
                                self.newton.inverted)
        text = failure.message(stage, unit_load, fail.why, region)
        return SolveError(text, last_converged=last, residuals=res.residuals if res else [],
                          stage=stage, region=region, hint=failure.HINTS[stage], partial=partial)

    def stats(self, t_start: float) -> dict:
        stats = self.newton.stats.as_dict()
        stats.update(unknowns=int(self.model.free.size), tets=int(self.model.edofs.shape[0]),
                     total_s=time.perf_counter() - t_start)
        return stats


class _Curve:
    """The curve as it is solved: the :class:`Step`, the node shape and the displacement of
    every reported state, and what ended it (``found``: the stretch, the pressure maximum, the
    instability and its mode)."""

    def __init__(self, setup: _Setup, mesh: TetMesh, blocked: bool, max_stretch: float | None,
                 t_start: float):
        self.setup, self.mesh, self.blocked = setup, mesh, blocked
        self.max_stretch, self.t_start = max_stretch, t_start
        self.steps: list[Step] = []
        self.shapes: list[np.ndarray] = []
        self.states: list[np.ndarray] = []
        self.contact: list[np.ndarray] = []  # the nodal contact pressure (MPa) of every state, with self-contact
        self.found: dict[str, object] = {}

    def report(self, state: State) -> tuple[bool, float]:
        """Record a converged state; whether the curve stops there (stretch, the tip on the base
        with self-contact, full bend)."""
        setup, blocked, max_stretch = self.setup, self.blocked, self.max_stretch
        step = setup.observer.step(1000.0 * state.p, state.u, state.ev, blocked)
        self.steps.append(step)
        self.shapes.append(state.u.reshape(-1, 3)[:self.mesh.n_nodes].copy())
        self.states.append(state.u.copy())
        touch = setup.model.contact
        if touch is not None:
            self.contact.append(touch.nodal_pressure(setup.model.X + state.u.reshape(-1, 3)))
        log.info("%.4g kPa: angle %.1f deg, tip (%.2f, %.2f) mm, volume %.4g mL%s",
                 step.pressure_kpa, step.bend_angle_deg, step.tip_x_mm, step.tip_z_mm,
                 step.cavity_volume_ml, f", force {step.force_n:.3g} N" if blocked else "")
        if max_stretch is not None and step.max_principal_stretch > max_stretch:
            self.found["stretch"] = step
            return True, step.bend_angle_deg
        if touch is not None and touch.options.stop_where_ends_meet and not blocked and state.p > 0:
            pairs, force = touch.ends_meet(setup.model.X + state.u.reshape(-1, 3), setup.model.X)
            if pairs:
                self.found["ends_meet"] = (step, pairs, force * setup.observer.scale)
                return True, step.bend_angle_deg
        full = (setup.options.stop_at_full_bend and not blocked
                and step.bend_angle_deg >= FULL_BEND_DEG)
        return full, step.bend_angle_deg

    def at_maximum(self, state: State) -> None:
        """Record the pressure maximum at ``state``."""
        step = self.setup.observer.step(1000.0 * state.p, state.u, state.ev, self.blocked)
        self.found["maximum"] = PressureMaximum(step.pressure_kpa, step.bend_angle_deg,
                                                step.cavity_volume_ml)

    def partial(self, reason: str) -> Solution:
        """The curve up to here, as a failed :class:`Solution`."""
        shapes = self.shapes
        return Solution(tuple(self.steps), shapes[-1] if shapes else np.zeros((self.mesh.n_nodes, 3)),
                        None, reason, self.setup.stats(self.t_start), tuple(shapes), tuple(self.states),
                        "failed", self.found.get("maximum"), tuple(self.contact))


@one_blas_thread
def _curve(mesh: TetMesh, material: Yeoh, membrane: Membrane | None, pmax: float,
           targets: list[float] | None, gravity: Sequence[float] | None,
           plane_gap_mm: float | None, options: SolveOptions,
           regions: Mapping[str, Yeoh] | None) -> Solution:
    t_start = time.perf_counter()
    blocked = plane_gap_mm is not None
    plane = mesh.tip_mm[2] - plane_gap_mm if blocked else None
    setup = _Setup(mesh, material, membrane, gravity, plane, options, regions)
    stage = "blocked force" if blocked else "pressure"
    max_stretch = options.max_stretch or material.stretch_at_break
    curve = _Curve(setup, mesh, blocked, max_stretch, t_start)
    try:
        why = _stages(curve, stage, pmax, targets)
    finally:
        setup.newton.linear.release()
    stop, reason, fb = _stop(why, curve.steps, curve.found, blocked, max_stretch)
    stats = setup.stats(t_start)
    log.info("curve: %d unknowns, %d increments, %d factorisations (%s), %.1f s; %s",
             stats["unknowns"], stats["increments"], stats["factorizations"],
             ", ".join(f"{k} {v}" for k, v in stats["stage_factorizations"].items()),
             stats["total_s"], reason or "full bend")
    displacement = curve.shapes[-1]
    return Solution(tuple(curve.steps), displacement, fb, reason, stats, tuple(curve.shapes),
                    tuple(curve.states), stop, curve.found.get("maximum"), tuple(curve.contact),
                    curve.found.get("rest_weight_g"))


def _stages(curve: _Curve, stage: str, pmax: float, targets: list[float] | None) -> str:
    """Gravity, then the pressure (``stage``); why the pressure stage ended. A critical point
    ends the curve as ``instability``; any other failure raises :class:`SolveError`."""
    setup = curve.setup
    state, failed, critical_load = _gravity_stage(curve)
    curve.report(State(state.t, state.u, 0.0, state.ev, state.stresses))
    n0 = setup.newton.stats.factorizations
    if failed is None:
        why, failed, critical_load = _pressure_stage(curve, state, pmax, targets)
    if critical_load is not None:  # a physical end
        why = _instability(curve, failed, critical_load)
    elif failed is not None:
        _raise_pressure_failure(curve, stage, failed)
    setup.newton.stats.stage_factorizations[stage] = setup.newton.stats.factorizations - n0
    return why


def _gravity_stage(curve: _Curve) -> tuple[State, PathFailure | None, Load | None]:
    """The rest state under its weight; at a critical point (it buckles under its own weight:
    a physical end) the last converged state, the failure and the load there."""
    setup = curve.setup
    state = setup.rest()
    try:
        return setup.gravity(state), None, None
    except PathFailure as fail:
        if not fail.critical:
            err = setup.error("gravity", fail, f"{fail.last.t:.4g} g of {fail.target:.4g} g "
                              "(no pressure yet)", None, 0.0)
            err.partial = curve.partial(str(err))
            raise err from None
        critical_load = setup.load(0.0, fail.last.t)
        curve.found["rest_weight_g"] = float(fail.last.t)
        curve.found["instability_where"] = (f", under {fail.last.t:.3g} g of its own weight and before any "
                                            f"pressure (the last try {fail.target - fail.last.t:.2g} g more)")
        return fail.last, fail, critical_load


def _pressure_stage(curve: _Curve, state: State, pmax: float, targets: list[float] | None
                    ) -> tuple[str | None, PathFailure | None, Load | None]:
    """Inflate from ``state``: why it ended, or the failure (and the load at a critical point)."""
    setup, options = curve.setup, curve.setup.options
    try:
        _, why = inflate(setup.newton, state, setup.load, setup.angle, curve.report,
                         options.control(), p_limit=pmax / 1000.0,
                         targets=[p / 1000.0 for p in targets] if targets else None,
                         past_maximum=options.past_pressure_maximum, on_maximum=curve.at_maximum)
    except PathFailure as fail:
        critical_load = None
        if fail.critical and fail.last.p > 0:
            critical_load = setup.load(fail.last.p)
            curve.found["instability_where"] = (f" (the last try {abs(fail.target - fail.last.t) / 1000.0:.2g} "
                                                "mL further)")
        return None, fail, critical_load
    return why, None, None


def _instability(curve: _Curve, failed: PathFailure, critical_load: Load) -> str:
    """End the curve at the critical point after ``failed.last``: its step and softest mode."""
    setup, found = curve.setup, curve.found
    why, last = "instability", failed.last
    found["instability"] = setup.observer.step(1000.0 * last.p, last.u, last.ev, curve.blocked)
    found["instability_mode"] = failure.softest_mode(setup.newton, last.u, critical_load)
    if curve.steps[-1].pressure_kpa < found["instability"].pressure_kpa:
        curve.report(last)
    return why


def _raise_pressure_failure(curve: _Curve, stage: str, failed: PathFailure) -> NoReturn:
    """The pressure stage failed (not at a critical point): a :class:`SolveError` with the partial curve."""
    steps = curve.steps
    last = steps[-1].pressure_kpa if steps else 0.0
    err = curve.setup.error(stage, failed, f"{1000.0 * failed.last.p:.4g} kPa (last converged; "
                            f"bend {steps[-1].bend_angle_deg:.1f} deg)", None, last)
    err.args = (f"{err.args[0]}; last converged pressure {last:.4g} kPa",)
    err.partial = curve.partial(str(err))
    raise err from None


def _stop(why: str, steps: list[Step], found: dict, blocked: bool,
          max_stretch: float | None) -> tuple[str, str | None, float | None]:
    """(stop, reason, full-bend pressure) of a finished curve."""
    fb, reason = (None, "blocked-force curve") if blocked else full_bend_pressure(steps)
    if "stretch" in found:
        s = found["stretch"]
        x, y, z = s.max_stretch_at_mm
        return "stretch_limit", (
            f"the largest principal stretch {s.max_principal_stretch:.3g} at ({x:.1f}, {y:.1f}, "
            f"{z:.1f}) mm passed the material's stretch at break {max_stretch:.3g} at "
            f"{s.pressure_kpa:.4g} kPa and {s.bend_angle_deg:.1f} deg"), fb
    if "ends_meet" in found:
        s, pairs, force = found["ends_meet"]
        return "tip_meets_base", (
            f"the free end meets the clamped end at {s.pressure_kpa:.4g} kPa and {s.bend_angle_deg:.1f} deg "
            f"({pairs} contact pair{'s' if pairs > 1 else ''} carrying {force:.3g} N): the actuator's own body "
            "stops the bend there; the curve ends there"), fb
    if why == "instability":
        s = found["instability"]
        return "instability", (
            f"the actuator loses stability at {s.pressure_kpa:.4g} kPa, {s.bend_angle_deg:.1f} deg "
            f"and {s.cavity_volume_ml:.4g} mL{found['instability_where']}: its tangent turns "
            "singular (a negative eigenvalue appears: a limit point or a bifurcation of the "
            "equilibrium path, where the actuator snaps to another shape, e.g. a thin wall "
            "buckles or the body flops over under its weight; where: "
            f"{found['instability_mode']}); the curve ends there"), fb
    if why == "pressure_maximum":
        return "pressure_maximum", (f"{found['maximum'].describe()}: past it the actuator "
                                    "inflates at a falling pressure (it snaps under a "
                                    "pressure regulator); the curve ends there"), fb
    if fb is not None:
        return "full_bend", None, fb
    if why == "pressure_limit":
        last = steps[-1]
        return "pressure_limit", (f"bend angle reached {last.bend_angle_deg:.1f} deg at the "
                                  f"pressure limit {last.pressure_kpa:.4g} kPa"), fb
    return ("targets" if why == "targets" else "full_bend"), reason, fb


def solve_bending(mesh: TetMesh, material: Yeoh = ELASTOSIL_M4601,
                  membrane: Membrane | None = PAPER, *, max_pressure_kpa: float | None = None,
                  pressures_kpa: Sequence[float] | None = None,
                  gravity: Sequence[float] | None = None,
                  options: SolveOptions | None = None,
                  regions: Mapping[str, Yeoh] | None = None) -> Solution:
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
    regions : element-set name -> its rubber where it is not ``material`` (e.g. the
        ``bottom_layer`` cast in another silicone).

    Returns
    -------
    Solution : the steps up to full bend or another named stop (``Solution.stop``:
        ``full_bend``, ``pressure_limit``, ``pressure_maximum``, ``stretch_limit``, ``tip_meets_base``,
        ``instability``,
        ``targets``); ``reason`` says in words why a curve ended short of full bend.

    Raises
    ------
    SolveError : an increment failed after the allowed cuts; names the stage, the last
        converged pressure (``last_converged``, kPa), the region and what to try, keeps
        the residual history, and carries the curve up to the failure (``partial``).
    """
    pmax, targets = _pressures(max_pressure_kpa, pressures_kpa)
    return _curve(mesh, material, membrane, pmax, targets, gravity, None,
                  options or SolveOptions(), regions)


def solve_blocked_force(mesh: TetMesh, material: Yeoh = ELASTOSIL_M4601,
                        membrane: Membrane | None = PAPER, *,
                        max_pressure_kpa: float | None = None,
                        pressures_kpa: Sequence[float] | None = None, gap_mm: float = 0.0,
                        gravity: Sequence[float] | None = None,
                        options: SolveOptions | None = None,
                        regions: Mapping[str, Yeoh] | None = None) -> Solution:
    """Blocked tip force against a rigid frictionless plane ``z = tip_z - gap_mm``.

    Same parameters as :func:`solve_bending`; ``Step.force_n`` is the plane's reaction
    (N, whole actuator). Raises :class:`SolveError` like :func:`solve_bending`.
    """
    pmax, targets = _pressures(max_pressure_kpa, pressures_kpa)
    if gap_mm < 0:
        raise DesignError("gap_mm", f"must be >= 0, got {gap_mm}")
    return _curve(mesh, material, membrane, pmax, targets, gravity, float(gap_mm),
                  options or SolveOptions(), regions)
