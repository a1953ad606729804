"""The reference the compiled step model is tested against: scipy's Radau IIA (order 5,
L-stable, its own finite-difference Jacobian and event location) over the **same**
compiled right-hand side (:func:`pnmold.pneumatics.rates.rates`), segment by segment of
the valve schedule, sampled with its dense output at the schedule's times.

It returns a :class:`pnmold.pneumatics.model.Trajectory`, so the oracle's series come out
of the same :meth:`~pnmold.pneumatics.model.Trajectory.columns` as the compiled model's:
a difference between the two is the integrators' alone.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from pnmold.pneumatics.model import Lowered, StepModel, Trajectory
from pnmold.pneumatics.network import Rig
from pnmold.pneumatics.protocol import Schedule
from pnmold.pneumatics.rates import rates

RTOL = 1e-10
FIRST_STEP_S = 1e-6  # each valve phase starts with a jump in the flows


def radau(lowered: Lowered, schedule: Schedule, *, rtol: float = RTOL, event_deg: float | None = None) -> Trajectory:
    """The lowered model integrated by scipy's Radau over the schedule (rows before the
    valve opens keep the initial state)."""
    n = lowered.network.n
    m0 = float(np.sum(lowered.network.stored_mass_kg(lowered.y0[:n])))
    atol = np.concatenate([np.full(n, 1e-6), [1e-11, 1e-9, 1e-2 * rtol * m0]])
    t_out, switch = schedule.time_s, schedule.switch_s
    states = np.tile(lowered.y0, (t_out.size, 1))
    y = lowered.y0.copy()
    level = math.radians(event_deg) if event_deg is not None else math.inf
    event_t = None
    steps = 0
    for k, phase in enumerate(schedule.phases):
        t0, t1 = switch[k], switch[k + 1]

        def f(t, yy, phase=int(phase)):
            out = np.empty_like(yy)
            rates(yy, phase, lowered.net, lowered.mode, out)
            return out

        def crossing(t, yy):
            return yy[n] - level

        crossing.direction = 1.0
        events = [crossing] if event_t is None and math.isfinite(level) else None
        sol = solve_ivp(f, (t0, t1), y, method="Radau", rtol=rtol, atol=atol, dense_output=True,
                        first_step=FIRST_STEP_S, events=events)
        if sol.status < 0:
            raise RuntimeError(f"Radau failed at t = {sol.t[-1]:.6g} s: {sol.message}")
        steps += sol.t.size - 1
        if event_t is None and sol.t_events is not None and len(sol.t_events[0]):
            event_t = float(sol.t_events[0][0])
        last = k == schedule.phases.size - 1
        rows = (t_out >= t0) & ((t_out < t1) | (last & (t_out <= t1)))
        states[rows] = sol.sol(t_out[rows]).T
        y = sol.y[:, -1]
    states[t_out > switch[-1]] = y
    return Trajectory(lowered, schedule, states, event_t, steps)


def radau_step(model: StepModel, rig: Rig, schedule: Schedule, *, modulus_scale: float = 1.0, rtol: float = RTOL,
               event_deg: float | None = None) -> Trajectory:
    """:meth:`StepModel.integrate`'s trajectory, by the oracle."""
    return radau(model.lower(rig, modulus_scale), schedule, rtol=rtol, event_deg=event_deg)
