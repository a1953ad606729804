"""Time integration of the step response: scipy's Radau, or a fixed-step SDIRK2.

``radau`` (default): ``scipy.integrate.solve_ivp`` with the implicit Radau IIA method
(order 5, L-stable; the valve-side node is stiff), tight tolerances and exact event
location. ``sdirk2``: Alexander's two-stage, L-stable, stiffly accurate SDIRK of order 2
(gamma = 1 - 1/sqrt 2; Alexander, SIAM J. Numer. Anal. 14, 1977) with a fixed step
``dt_s`` and Newton on a finite-difference Jacobian -- the time-step refinement study
checks its observed order. Both preserve the linear invariant of the network (metered gas
= stored gas), as every Runge-Kutta method does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from pnmold.errors import SolveError

METHODS = ("radau", "sdirk2")
FIRST_STEP_S = 1e-6  # each valve phase starts with a jump in the flows
RTOL = 1e-7  # default relative tolerance (mass balance to ~1e-7; time to full bend to ~1e-8 s)


@dataclass
class Trajectory:
    """States at the output times and the first crossing time of the event (or None)."""

    t: np.ndarray
    y: np.ndarray  # (n_states, n_times)
    event_t: float | None


def integrate(rhs: Callable, y0: np.ndarray, t_out: np.ndarray, atol: np.ndarray, *, method: str = "radau",
              dt_s: float | None = None, event: Callable | None = None, event_slot: int | None = None,
              sparsity: np.ndarray | None = None, rtol: float = RTOL) -> Trajectory:
    """Integrate ``y' = rhs(t, y)`` from ``t_out[0]`` to ``t_out[-1]``, sampled at ``t_out``.

    ``event(t, y)`` rising through zero is located (first time only); for ``sdirk2`` it must
    be ``y[event_slot] - level`` with ``y[event_slot + 1]`` its rate (a position-velocity
    pair), located by a second-order expansion from the step's start. ``sparsity``: the
    Jacobian's pattern (fewer evaluations for Radau)."""
    if method == "radau":
        return _radau(rhs, y0, t_out, atol, event, sparsity, rtol)
    if method == "sdirk2":
        if dt_s is None or not dt_s > 0:
            raise ValueError("sdirk2 needs a time step dt_s > 0")
        return _sdirk2(rhs, y0, t_out, atol, dt_s, event, event_slot, rtol)
    raise ValueError(f"unknown method {method!r}; one of {', '.join(METHODS)}")


def _radau(rhs, y0, t_out, atol, event, sparsity, rtol) -> Trajectory:
    events = None
    if event is not None:
        def ev(t, y):
            return event(t, y)
        ev.direction = 1.0
        events = [ev]
    sol = solve_ivp(rhs, (t_out[0], t_out[-1]), y0, method="Radau", t_eval=t_out, rtol=rtol, atol=atol,
                    events=events, jac_sparsity=sparsity, first_step=FIRST_STEP_S)
    if sol.status < 0:
        raise SolveError(f"the pneumatic ODE failed at t = {sol.t[-1]:.6g} s: {sol.message}",
                         last_converged=float(sol.t[-1]))
    first = None
    if events is not None and len(sol.t_events[0]):
        first = float(sol.t_events[0][0])
    return Trajectory(sol.t, sol.y, first)


def _jacobian(rhs, t, y, f0, scale):
    n = len(y)
    jac = np.empty((n, n))
    for j in range(n):
        h = 1e-7 * max(abs(y[j]), scale[j] * 1e3)
        yp = y.copy()
        yp[j] += h
        jac[:, j] = (rhs(t, yp) - f0) / h
    return jac


def _sdirk2(rhs, y0, t_out, atol, dt_s, event, event_slot, rtol) -> Trajectory:
    gamma = 1 - 1 / math.sqrt(2)
    span = t_out[-1] - t_out[0]
    out_dt = np.diff(t_out)
    # a step that divides every output interval: outputs fall on steps
    per = max(1, int(math.ceil(out_dt.min() / dt_s - 1e-9)))
    h = out_dt.min() / per
    if not np.allclose(out_dt / h, np.round(out_dt / h), rtol=0, atol=1e-6):
        raise ValueError("sdirk2 needs evenly spaced output times")
    n_steps = int(round(span / h))
    eye = np.eye(len(y0))

    def refresh(tt, yy):
        return scipy.linalg.lu_factor(eye - h * gamma * _jacobian(rhs, tt, yy, rhs(tt, yy), atol))

    y = np.array(y0, float)
    t = float(t_out[0])
    f = rhs(t, y)
    ys = [y.copy()]
    event_t = None
    lu = None
    for step in range(1, n_steps + 1):
        if lu is None or step % 8 == 0:
            lu = refresh(t, y)
        k1, lu = _stage(rhs, t + gamma * h, y, h * gamma, y + h * gamma * f, atol, lu, refresh, rtol)
        base = y + h * (1 - gamma) * k1
        k2, lu = _stage(rhs, t + h, base, h * gamma, base + h * gamma * k1, atol, lu, refresh, rtol)
        y_new = base + h * gamma * k2
        t_new = t_out[0] + step * h
        f_new = k2  # stiffly accurate: the last stage is the new state
        if event is not None and event_t is None and event(t, y) < 0 <= event(t_new, y_new):
            event_t = _taylor_root(t, h, y[event_slot] - event(t, y), y[event_slot], f[event_slot],
                                   f[event_slot + 1])
        y, t, f = y_new, t_new, f_new
        if step % per == 0:
            ys.append(y.copy())
    return Trajectory(np.asarray(t_out, float), np.array(ys).T, event_t)


def _stage(rhs, t, base, hg, guess, atol, lu, refresh, rtol):
    """Solve Y = base + hg f(t, Y) by Newton, refreshing the Jacobian whenever the
    simplified iteration contracts slowly (near the valve's switch-on transient).

    Returns f(t, Y) (so the update keeps the network's linear invariant to round-off)."""
    y = guess.copy()
    previous = np.inf
    for _ in range(40):
        residual = y - base - hg * rhs(t, y)
        delta = scipy.linalg.lu_solve(lu, -residual)
        y += delta
        size = np.max(np.abs(delta) / (atol + 1e-3 * rtol * np.abs(y)))
        if size < 1.0:
            return rhs(t, y), lu
        if size > 0.3 * previous:
            lu = refresh(t, y)
        previous = size
    raise SolveError(f"SDIRK2 Newton did not converge at t = {t:.6g} s; use a smaller time step",
                     last_converged=float(t))


def _taylor_root(t0, h, level, x0, v0, a0) -> float:
    """First s in [0, h] with x0 + v0 s + a0 s^2 / 2 = level: the crossing from the step's
    start alone (the step's end may already feel what the event switches on, the contact)."""
    def quadratic(s):
        return x0 + v0 * s + 0.5 * a0 * s * s - level

    if quadratic(h) < 0:  # the expansion falls short within the step: take its end
        return t0 + h
    return t0 + brentq(quadratic, 0.0, h, xtol=1e-15)
