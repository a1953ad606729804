"""Path following: a load ramped by load control, the pressure by cavity-volume control.

Why volume control for the pressure (rather than arc-length on the pressure): the cavity
volume is what a syringe pump prescribes (the supplement's P-V test), it is one physical
scalar (no mixing of displacement and pressure units in an arc-length norm, no choice
between two roots), and it is monotone along the equilibrium path wherever the actuator
is stable under a syringe, which includes the states past a pressure maximum where
pressure control has no nearby solution (a ballooning wall, a snap). The pressure is an
unknown of the bordered Newton system (:mod:`.newton`); a pressure maximum shows as the
pressure falling from one converged volume to the next, and is located and reported,
not mistaken for a failure. Requested pressures are landed on exactly by a pressure-
controlled solve from an interpolated predictor.

Step control: the first increment comes from the tangent at the start (``first_angle_deg``
of predicted bend, at most ``first_move`` of the body's size), later ones grow or shrink
with the tangents an increment used (``target_iterations``) and are limited by
``max_angle_deg`` of bend. Predictors extrapolate the last converged states (Lagrange,
``predictor_order``): points move on arcs as the actuator curls, and a higher-order
prediction leaves Newton a smaller spurious stretch to remove. A failed increment is
halved; ``max_cuts`` halvings in a row end the stage with :class:`PathFailure`, marked
``critical`` when the shortest tries met a tangent (predicted or iterated) that lost stability
against the last converged state, or the converged states lost it during the stage (counted
under the volume constraint: past a pressure maximum K has a negative pivot the syringe
removes, so crossing a maximum is not mistaken for one) -- the solver then ends the curve
there as the named stop ``instability``. A failed try within :data:`CRITICAL_RESOLUTION` of the
last converged state that meets such a tangent ends the stage the same way at once: the
critical point is then located, and converged increments (which restart the halvings) would
only creep toward it.

The converged states, the predictors through them, the increments' sizes and
:class:`PathFailure` are in :mod:`.states`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from .model import Evaluation, Load, Stresses
from .newton import Newton
from .newton_types import NewtonResult
from .states import (
    Control,
    OnStep,
    PathFailure,
    State,
    clear_of_contact,
    extrapolate,
    first_increment,
    interpolate_volume,
    next_increment,
    peak_volume,
    predictor_order,
)

log = logging.getLogger(__name__)


#: halvings before a failed increment's last try counts as short enough to tell a critical
#: point from a predictor that went too far (1/16 of the first try)
CRITICAL_AFTER_CUTS = 4
#: a try this close to the last converged state (a share of the stage's load range, or of the
#: volume travelled under volume control) is short enough too: a critical point located to
#: 1e-4 g is located. (Not a share of the cavity: early in an inflation short tries can fail
#: with a less stable predicted tangent on a smooth path -- CalculiX's pointwise penalty on the
#: coarse fPN stopped at 4.0 of its 6 kPa.) Closing in further only crawls: converged
#: increments reset the halvings, so the path crept toward the point geometrically (an Ecoflex
#: 00-30 sPN hanging chambers up spent 300 of its 365 s and 630 of its 698 factorisations going
#: from 0.6988 g to within 1e-16 g of its buckling load)
CRITICAL_RESOLUTION = 1e-4


def _critical(newton: Newton, cuts: int, base: int, near: bool = False) -> bool:
    """Whether the last try, at least :data:`CRITICAL_AFTER_CUTS` halvings short or ``near``
    the last converged state, met (at its prediction or any iterate) a tangent with more
    negative eigenvalues than the last converged state's, or the converged states themselves
    lost stability during the stage (more negative eigenvalues than ``base``, the count at its
    start): either way the path runs into a singular tangent, which a load-controlled stage
    cannot follow past."""
    if (cuts < CRITICAL_AFTER_CUTS and not near) or newton.inertia < 0:
        return False
    return newton.most_negatives > newton.inertia or newton.inertia > base


def _tangent_load(newton: Newton, state: State, load: Load, rhs: np.ndarray) -> np.ndarray:
    """``K^-1 rhs`` at ``state`` (one factorisation), full length."""
    m = newton.model
    newton.factor(state.u, load)
    out = np.zeros(m.ndof)
    out[m.free] = newton.back_solve(rhs[m.free])
    return out


def ramp(newton: Newton, start: State, load_at: Callable[[float], Load], t_end: float,
         angle: Callable[[np.ndarray], float], on_step: OnStep, control: Control,
         targets: Sequence[float] | None = None, what: str = "load", unit: str = "",
         first_step: float | None = None) -> State:
    """Load control: march ``t`` from ``start.t`` to ``t_end`` (landing on ``targets``).

    The load must be affine in ``t`` (dead loads, or a fixed-pressure ramp). ``on_step``
    is called at every converged increment, or only at the targets when given;
    ``first_step`` overrides the tangent's choice of the first increment.
    """
    opt = newton.options
    t = start.t
    stops = sorted({*(targets or ()), t_end})
    eps = 1e-12 * max(1.0, abs(t_end))
    span = abs(t_end - t)
    load0, load1 = load_at(t), load_at(t + 1.0)
    rate_rhs = -(newton.evaluate(start.u, load1).residual - newton.evaluate(start.u, load0).residual)
    rate_u = _tangent_load(newton, start, load0, rate_rhs)
    base = newton.inertia
    dt = first_step or first_increment(newton, rate_u, angle, start, control)
    dt = min(dt, t_end - t)
    history, state, cuts, last_angle = [start], start, 0, angle(start.u)
    done = 0.0  # the work of the load so far (N mm), the scale of Newton's energy criterion
    while t < t_end - eps:
        nxt = next(s for s in stops if s > t + eps)
        t_new = nxt if nxt - (t + dt) < 0.1 * dt else t + dt
        if not t_new > t:  # the increment vanished in rounding: a stall, said as one
            raise PathFailure(what, state, t_new, None,
                              f"the {what} increment shrank to {dt:.3g} {unit}, below rounding",
                              _critical(newton, CRITICAL_AFTER_CUTS, base))
        predict = partial(_ramp_prediction, list(history), rate_u, predictor_order(newton, state))
        t_new, (u_pred, _, s_pred) = clear_of_contact(newton, state, t_new, predict)
        work = done + abs(float((t_new - t) * rate_rhs @ (u_pred - state.u)))
        res = newton.solve(u_pred, load_at(t_new), stresses=s_pred, work=work, strict=cuts < 2)
        if not res.converged:
            cuts += 1
            newton.stats.cuts += 1
            log.info("%s %.4g %s: Newton failed (%s; residuals %s); cutting the step", what,
                     t_new, unit, res.why, ", ".join(f"{h:.2e}" for h in res.residuals[-4:]))
            near = t_new - t <= CRITICAL_RESOLUTION * span
            if cuts > opt.max_cuts or (near and _critical(newton, cuts, base, near)):
                raise PathFailure(what, state, t_new, res, f"failed after {cuts - 1} cuts: {res.why}",
                                  _critical(newton, cuts, base, near))
            dt = 0.5 * (t_new - t)
            continue
        newton.stats.increments += 1
        done += abs(float((t_new - t) * rate_rhs @ (res.u - state.u)))
        step, t, cuts = t_new - t, t_new, 0
        state = State(t, res.u, res.pressure_mpa, res.evaluation, res.stresses)
        history = (history + [state])[-(opt.predictor_order + 1):]
        bend = angle(state.u)
        log.info("%s %.4g %s: bend %.1f deg, %d factorisations", what, t, unit, bend,
                 res.factorizations)
        dt = next_increment(newton, step, res.tangents, abs(bend - last_angle), 0.0, control)
        last_angle = bend
        if targets is None or any(abs(t - s) <= eps for s in stops):
            stop, _ = on_step(state)
            if stop:
                break
    return state


def _ramp_prediction(history: Sequence[State], rate_u: np.ndarray, order: int, t_try: float
                     ) -> tuple[np.ndarray, float, Stresses | None]:
    """The predicted state of a load-controlled increment to ``t_try``: along the start's tangent
    after the start, then extrapolated through the converged states."""
    if len(history) == 1:
        return history[0].u + (t_try - history[0].t) * rate_u, 0.0, history[0].stresses
    return extrapolate(history, t_try, order)


def continuation(newton: Newton, u: np.ndarray, load_at: Callable[[float], Load], t0: float,
                 t1: float, first: float, max_step: float,
                 on_step: Callable[[float, np.ndarray, Evaluation], tuple[bool, float]],
                 targets: Sequence[float] | None = None, what: str = "load",
                 unit: str = "") -> tuple[float, np.ndarray]:
    """Load control from ``t0`` (``u`` converged there) to ``t1`` without a bend angle:
    ``on_step(t, u, ev) -> (stop, unused)``; returns the last converged ``(t, u)``."""
    start = State(t0, u, load_at(t0).pressure_mpa, newton.evaluate(u, load_at(t0)))

    def report(state: State) -> tuple[bool, float]:
        return on_step(state.t, state.u, state.ev)[0], 0.0

    end = ramp(newton, start, load_at, t1, lambda _: 0.0, report, Control(max_step=max_step),
               targets, what, unit, first_step=first)
    return end.t, end.u


def inflate(newton: Newton, start: State, load_at: Callable[[float], Load],
            angle: Callable[[np.ndarray], float], on_step: OnStep, control: Control, *,
            p_limit: float, targets: Sequence[float] | None = None,
            past_maximum: bool = False,
            on_maximum: Callable[[State], None] | None = None) -> tuple[State, str]:
    """Volume control from ``start`` (pressure ``start.p``, MPa) until a stop.

    ``load_at(p)`` is the load at pressure ``p`` (MPa). Every converged increment is
    reported through ``on_step``, or only the ``targets`` (MPa) when given. Returns the
    last reported state and why the stage ended: ``"pressure_limit"`` (``p_limit``
    reached, landed on exactly), ``"targets"`` (the last target), ``"stopped"``
    (``on_step`` asked) or ``"pressure_maximum"`` (the pressure fell: ``on_maximum``
    gets the state at the maximum, which is then the last state unless
    ``past_maximum``).
    """
    opt = newton.options
    first, rate_u, rate_p, compliance, base = _volume_rates(newton, start, load_at)
    stage = _Inflation(newton, load_at, first, rate_u, rate_p, base, on_step, p_limit, targets,
                       past_maximum, on_maximum)
    dv = first_increment(newton, rate_u, angle, first, control)
    if math.isfinite(control.max_pressure_step_mpa):
        dv = min(dv, control.max_pressure_step_mpa * compliance)
    pending = sorted({*(p for p in (targets or ()) if p > first.p), p_limit})
    pending = [p for p in pending if p <= p_limit]
    history, state, cuts = [first], first, 0
    last_angle = angle(first.u)
    peaked = False
    done = 0.0  # the work of the pressure so far (N mm), the scale of Newton's energy criterion
    while True:
        v_new, res = _volume_try(stage, history, state, dv, done, cuts)
        if not res.converged:
            cuts = _failed_try(stage, state, v_new, v_new - state.t, res, cuts)
            dv = 0.5 * (v_new - state.t)
            continue
        newton.stats.increments += 1
        new = State(v_new, res.u, res.pressure_mpa, res.evaluation, res.stresses)
        done += abs(0.5 * (new.p + state.p) * (new.t - state.t))
        bend = angle(new.u)
        log.info("pressure %.4g kPa (volume +%.4g mL): bend %.1f deg, %d factorisations%s",
                 1000.0 * new.p, (new.t - first.t) / 1000.0, bend, res.factorizations,
                 f", sheet {100 * new.ev.wrinkled:.0f}% wrinkled" if new.ev.wrinkled else "")
        ptol = 1e-5 * abs(state.p) + 1e-12
        if not peaked and new.p < state.p - ptol:
            peaked = True
            top = _maximum(stage, history + [new], state, done)
            if top is not None:
                return top, "pressure_maximum"
        landings = _landings(stage, history + [new], state, new, pending, done)
        if landings is None:
            cuts += 1  # a requested pressure could not be landed on: a shorter increment
            newton.stats.cuts += 1
            if cuts > opt.max_cuts:
                raise PathFailure("pressure", state, v_new, res,
                                  f"landing on a requested pressure failed after {cuts - 1} cuts")
            dv = 0.5 * (v_new - state.t)
            continue
        end = _report(stage, landings, new, pending)
        if end is not None:
            return end
        history = (history + [new])[-(opt.predictor_order + 2):]
        dp = new.p - state.p
        dv = next_increment(newton, v_new - state.t, res.tangents, abs(bend - last_angle),
                        dp, control)
        state, last_angle, cuts = new, bend, 0


@dataclass(frozen=True)
class _Inflation:
    """What a volume-controlled stage (:func:`inflate`) holds fixed: the solver and the load, the
    start (``t`` its cavity volume), the tangent's rates there and the count of negative
    eigenvalues held at the volume, the stops and the callbacks."""

    newton: Newton
    load_at: Callable[[float], Load]
    first: State
    rate_u: np.ndarray
    rate_p: float
    base: int
    on_step: OnStep
    p_limit: float
    targets: Sequence[float] | None
    past_maximum: bool
    on_maximum: Callable[[State], None] | None


def _volume_rates(newton: Newton, start: State, load_at: Callable[[float], Load]
                  ) -> tuple[State, np.ndarray, float, float, int]:
    """The start of a volume-controlled stage (``t`` its cavity volume), the rates of the
    displacement and the pressure with the volume there (one factorisation), the compliance
    dV/dp and the negative eigenvalues of the tangent held at the volume."""
    m = newton.model
    first = State(start.ev.cavity_volume_mm3, start.u, start.p, start.ev, start.stresses)
    newton.factor(first.u, load_at(first.p))
    g = first.ev.volume_gradient[m.free]
    a = newton.back_solve(g)
    compliance = float(g @ a)  # dV/dp at the start
    base = newton.negatives(g)
    rate_u = np.zeros(m.ndof)
    rate_u[m.free] = a / compliance
    rate_p = 1.0 / compliance
    return first, rate_u, rate_p, compliance, base


def _volume_try(stage: _Inflation, history: Sequence[State], state: State, dv: float, done: float,
                cuts: int) -> tuple[float, NewtonResult]:
    """The increment ``dv`` of the volume from ``state``: predicted (the start's tangent, then
    extrapolated) and solved by Newton; a :class:`PathFailure` where ``dv`` vanished in rounding."""
    newton = stage.newton
    v_new = state.t + dv
    if not v_new > state.t:  # the increment vanished in rounding: a stall, said as one
        raise PathFailure("pressure", state, v_new, None,
                          f"the volume increment shrank to {dv:.3g} mm^3, below rounding",
                          _critical(newton, CRITICAL_AFTER_CUTS, stage.base))
    def predict(v: float) -> tuple[np.ndarray, float, Stresses | None]:
        if len(history) == 1:
            return state.u + (v - state.t) * stage.rate_u, state.p + (v - state.t) * stage.rate_p, state.stresses
        return extrapolate(history, v, predictor_order(newton, state))

    v_new, (u_pred, p_pred, s_pred) = clear_of_contact(newton, state, v_new, predict)
    res = newton.solve(u_pred, stage.load_at(p_pred), volume=v_new, stresses=s_pred,
                       work=done + abs((p_pred - state.p) * (v_new - state.t)), strict=cuts < 2)
    return v_new, res


def _failed_try(stage: _Inflation, state: State, v_new: float, dv: float, res: NewtonResult,
                cuts: int) -> int:
    """Count Newton's failure at ``v_new`` as a cut and return the cuts; a :class:`PathFailure`
    after ``max_cuts``, or at once where a try close to ``state`` met a critical point."""
    newton = stage.newton
    cuts += 1
    newton.stats.cuts += 1
    log.info("volume %.5g mL: Newton failed (%s; residuals %s); cutting the step",
             v_new / 1000.0, res.why, ", ".join(f"{h:.2e}" for h in res.residuals[-4:]))
    near = dv <= CRITICAL_RESOLUTION * (state.t - stage.first.t)
    if cuts > newton.options.max_cuts or (near and _critical(newton, cuts, stage.base, near)):
        raise PathFailure("pressure", state, v_new, res, f"failed after {cuts - 1} cuts: {res.why}",
                          _critical(newton, cuts, stage.base, near))
    return cuts


def _maximum(stage: _Inflation, history: Sequence[State], state: State, work: float) -> State | None:
    """The pressure fell from ``state`` to ``history[-1]``: the maximum between them located and
    given to ``on_maximum``; the state there when the stage ends at it, else None."""
    top = _solve_peak(stage.newton, history, stage.load_at, work)
    fresh = top is not None and top.p > state.p and top.t > state.t
    top = top if fresh else state  # the last state on the rise, already reported
    log.info("pressure maximum %.4g kPa at volume +%.4g mL", 1000.0 * top.p,
             (top.t - stage.first.t) / 1000.0)
    if stage.on_maximum is not None:
        stage.on_maximum(top)
    if stage.past_maximum:
        return None
    if stage.targets is None and fresh:
        stage.on_step(top)
    return top


def _landings(stage: _Inflation, history: Sequence[State], state: State, new: State,
              pending: Sequence[float], work: float) -> list[State] | None:
    """The converged states at the ``pending`` pressures passed from ``state`` to ``new``
    (``history[-1]``), in order; None when one could not be landed on."""
    landings = []
    for target in [q for q in pending if state.p < q <= new.p]:
        landed = _land(stage.newton, history, target, stage.load_at, work)
        if landed is None:
            break
        landings.append(landed)
    if len(landings) < sum(state.p < q <= new.p for q in pending):
        return None
    return landings


def _report(stage: _Inflation, landings: Sequence[State], new: State, pending: list[float]
            ) -> tuple[State, str] | None:
    """Report the ``landings`` (popping their pressures from ``pending``), then ``new`` where
    every increment is reported; ``(state, why)`` when the stage ends there, else None."""
    for landed in landings:
        target = pending.pop(0)
        stop, _ = stage.on_step(landed)
        if target >= stage.p_limit:
            return landed, "pressure_limit"
        if stage.targets is not None and not pending:
            return landed, "targets"
        if stop:
            return landed, "stopped"
    if new.p >= stage.p_limit:  # exactly on the limit: already reported as landed
        return new, "pressure_limit"
    if stage.targets is None:
        stop, _ = stage.on_step(new)
        if stop:
            return new, "stopped"
    return None


def _solve_peak(newton: Newton, history: Sequence[State], load_at: Callable[[float], Load],
                work: float) -> State | None:
    """The converged state at the located pressure maximum (volume control), or None."""
    v = peak_volume(history)
    u_pred, p_pred, s_pred = extrapolate(history, v, min(predictor_order(newton, history[-1]),
                                                         len(history) - 1))
    res = newton.solve(u_pred, load_at(p_pred), volume=v, stresses=s_pred, work=work,
                       strict=False)
    return (State(v, res.u, res.pressure_mpa, res.evaluation, res.stresses) if res.converged
            else None)


def _land(newton: Newton, history: Sequence[State], p_target: float,
          load_at: Callable[[float], Load], work: float) -> State | None:
    """The converged state at exactly ``p_target`` between the last two states (pressure
    control from an interpolated predictor), or None."""
    order = min(predictor_order(newton, history[-1]), len(history) - 1)
    v = interpolate_volume(history, p_target, order)
    u_pred, _, s_pred = extrapolate(history, v, order)
    res = newton.solve(u_pred, load_at(p_target), stresses=s_pred, work=work, strict=False)
    if not res.converged:
        log.info("landing on %.4g kPa failed (%s)", 1000 * p_target, res.why)
        return None
    return State(res.evaluation.cavity_volume_mm3, res.u, p_target, res.evaluation,
                 res.stresses)
