"""The states of path following (:mod:`.path`), its step control and the predictors.

- :class:`State` -- a converged state; :class:`Control` -- the step control of a stage;
  :class:`PathFailure` -- an increment that failed after the allowed cuts;
- :func:`extrapolate` -- the Lagrange predictor through the last converged states, of the order
  :func:`predictor_order` gives;
- :func:`first_increment`, :func:`next_increment` -- the first increment of a stage (from its
  tangent) and the next one (from the tangents and the bend of the last);
- :func:`clear_of_contact` -- an increment shortened while its prediction drives walls into each
  other (with self-contact);
- :func:`interpolate_volume`, :func:`peak_volume` -- under volume control, the volume of a
  requested pressure and of a pressure maximum between the last converged states.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .model import Evaluation, Stresses
from .newton import Newton
from .newton_types import NewtonResult


@dataclass
class State:
    """A converged state: path parameter ``t``, displacement, pressure (MPa), evaluation
    and its stresses (for the mixed Newton's predicted tangent)."""

    t: float
    u: np.ndarray
    p: float
    ev: Evaluation
    stresses: Stresses | None = None


@dataclass(frozen=True)
class Control:
    """Step control of one stage (``t`` in the stage's own unit)."""

    first_angle_deg: float = 8.0
    first_move: float = 0.03
    max_angle_deg: float = 40.0
    max_step: float = math.inf
    max_pressure_step_mpa: float = math.inf


class PathFailure(Exception):
    """An increment failed after the allowed cuts; ``last`` is the last converged state.

    ``critical``: at the last try, cut at least :data:`.path.CRITICAL_AFTER_CUTS` times or within
    :data:`.path.CRITICAL_RESOLUTION` of ``last``, the predicted state's tangent had more negative eigenvalues than
    at ``last`` (under volume control, of the system held at the cavity volume): the
    equilibrium path meets a critical point (a limit point or a bifurcation) within that
    step -- the model loses stability there -- rather than Newton failing on a smooth path.
    """

    def __init__(self, what: str, last: State, target: float, result: NewtonResult | None,
                 why: str, critical: bool = False):
        self.what, self.last, self.target, self.result, self.why = what, last, target, result, why
        self.critical = critical
        super().__init__(why)


#: on_step(state) -> (stop, bend angle in degrees); ``stop`` ends the stage there.
OnStep = Callable[[State], tuple[bool, float]]


def extrapolate(history: Sequence[State], t_new: float, order: int
                ) -> tuple[np.ndarray, float, Stresses | None]:
    """Lagrange extrapolation (or interpolation) of ``(u, p, stresses)`` to ``t_new``
    through the last ``order + 1`` states."""
    pts = list(history[-(order + 1):])
    weights = []
    for i, si in enumerate(pts):
        w = 1.0
        for j, sj in enumerate(pts):
            if j != i:
                w *= (t_new - sj.t) / (si.t - sj.t)
        weights.append(w)
    u = sum(w * s.u for w, s in zip(weights, pts, strict=True))
    p = float(sum(w * s.p for w, s in zip(weights, pts, strict=True)))
    stresses = None
    if all(s.stresses is not None for s in pts):
        stresses = pts[-1].stresses.combine(weights, [s.stresses for s in pts])
    return u, p, stresses


def predictor_order(newton: Newton, state: State) -> int:
    """The order of the extrapolation from ``state``: the Newton options', at most
    :attr:`~.contact.SelfContact.predictor_order` where self-contact pairs are active there."""
    order = newton.options.predictor_order
    touch = newton.model.contact
    if touch is not None and state.ev is not None and state.ev.contact_pairs:
        order = min(order, touch.options.predictor_order)
    return order


def first_increment(newton: Newton, rate_u: np.ndarray, angle: Callable[[np.ndarray], float],
                    start: State, control: Control) -> float:
    """The increment of ``t`` whose tangent prediction bends ``first_angle_deg`` and moves
    no node more than ``first_move`` of the body's size."""
    big = float(np.max(np.abs(rate_u))) if rate_u.size else 0.0
    if big == 0.0:
        return math.inf
    probe = 0.01 * newton.span / big  # a small step: the angle's rate by difference
    rate_angle = abs(angle(start.u + probe * rate_u) - angle(start.u)) / probe
    dt = control.first_move * newton.span / big
    if rate_angle > 0:
        dt = min(dt, control.first_angle_deg / rate_angle)
    return dt


def next_increment(newton: Newton, dt: float, tangents: int, dangle: float, dp: float,
                   control: Control) -> float:
    """The increment of ``t`` after one of ``dt`` that used ``tangents`` tangents and moved the
    bend ``dangle`` degrees and the pressure ``dp``: grown or shrunk toward the target tangents,
    limited by the control's bend and pressure steps."""
    opt = newton.options
    grow = min(max(opt.target_iterations / max(tangents, 1), 0.5), opt.growth)
    out = dt * grow
    if dangle > 1e-9:
        out = min(out, dt * control.max_angle_deg / dangle)
    if dp > 0 and math.isfinite(control.max_pressure_step_mpa):
        out = min(out, dt * control.max_pressure_step_mpa / dp)
    return min(out, control.max_step)


def _pressure_at(history: Sequence[State], t: float, order: int) -> float:
    pts = list(history[-(order + 1):])
    p = 0.0
    for i, si in enumerate(pts):
        w = 1.0
        for j, sj in enumerate(pts):
            if j != i:
                w *= (t - sj.t) / (si.t - sj.t)
        p += w * si.p
    return p


def interpolate_volume(history: Sequence[State], p_target: float, order: int) -> float:
    """The volume between the last two states where the interpolated pressure is
    ``p_target`` (bisection on the Lagrange interpolant; the pressure rises there)."""
    lo, hi = history[-2].t, history[-1].t
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _pressure_at(history, mid, order) < p_target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def peak_volume(history: Sequence[State]) -> float:
    """Volume of the pressure maximum: vertex of the parabola through the last three
    (volume, pressure) points, kept inside their span."""
    if len(history) < 3:
        return history[-2].t
    (t0, p0), (t1, p1), (t2, p2) = [(s.t, s.p) for s in history[-3:]]
    d01, d12 = (p1 - p0) / (t1 - t0), (p2 - p1) / (t2 - t1)
    curv = (d12 - d01) / (t2 - t0)
    if curv >= 0:
        return t1
    vertex = 0.5 * (t0 + t1) - d01 / (2.0 * curv)
    return min(max(vertex, t0), t2)


#: halvings of an increment at most while its prediction closes a contact pair too far
#: (:func:`clear_of_contact`; assumed: where 1/64 of the increment still closes it, the increment
#: is solved as it was asked)
MAX_CONTACT_SHORTENINGS = 6


def clear_of_contact(newton: Newton, state: State, t_new: float,
                     predict: Callable[[float], tuple[np.ndarray, float, Stresses | None]]
                     ) -> tuple[float, tuple[np.ndarray, float, Stresses | None]]:
    """The increment from ``state`` to ``t_new`` and its prediction ``predict(t)``, the increment
    halved while the predicted state brings a self-contact pair closer than
    :attr:`~.contact.SelfContact.predicted_closing` allows (a prediction that drives walls into
    each other: its first tangent then fails as too long, after a factorisation); unchanged
    without self-contact, and where even :data:`MAX_CONTACT_SHORTENINGS` halvings leave the pair
    too close (it closes at once, not along the prediction: shortening would only crawl)."""
    pred = predict(t_new)
    touch = newton.model.contact
    if touch is None:
        return t_new, pred
    x0 = newton.model.X
    floor = touch.options.predicted_closing * touch.options.activation_mm
    floor = min(floor, touch.closest_gap(x0 + state.u.reshape(-1, 3)) - floor)
    t_try, tried = t_new, pred
    for _ in range(MAX_CONTACT_SHORTENINGS + 1):
        if touch.closest_gap(x0 + tried[0].reshape(-1, 3)) >= floor:
            newton.stats.contact_shortenings += int(round(math.log2((t_new - state.t) / (t_try - state.t))))
            return t_try, tried
        half = state.t + 0.5 * (t_try - state.t)
        if half == state.t:  # an increment at rounding's edge (a crawling path): not halved to nothing
            break
        t_try, tried = half, predict(half)
    # no shorter increment clears it: the pair closes at once (it switched to another triangle,
    # or appeared deep), not along the prediction; the increment is solved as it was asked
    return t_new, pred
