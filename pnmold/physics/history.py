"""History terms of the reduced model: what the material remembers of the protocol.

Both act on the pressure before the free law is read (the FE curve is the relaxed,
conditioned response at the nominal modulus):

- :func:`viscoelastic_pressure` -- one Prony term (standard linear solid) in pressure
  units: ``p = x + h``, ``dh/dt = g/(1-g) dx/dt - h/tau`` (g the Prony fraction of the
  instantaneous modulus, tau the relaxation time); ``x`` is the pressure the relaxed law
  sees. Integrated exactly for a pressure linear in time between rows.
- :func:`mullins_factor` -- stiffness factor of first-cycle softening (Ogden-Roxburgh
  idea, with the pressure as the damage measure): ``1 + f`` while the pressure exceeds
  every earlier one (first loading), ``1 + f (p / p_max)^n`` below the running maximum.
"""

from __future__ import annotations

import math

import numpy as np


def viscoelastic_pressure(pressure_kpa: np.ndarray, time_s: np.ndarray | None, fraction: float,
                          tau_s: float) -> np.ndarray:
    """The relaxed-equivalent pressure ``x`` of every row (``pressure_kpa`` itself if quasi-static)."""
    p = np.asarray(pressure_kpa, float)
    if fraction <= 0 or time_s is None or p.size < 2:
        return p.copy()
    gp = fraction / (1.0 - fraction)
    tau_c = tau_s * (1.0 + gp)  # retardation (creep) time under prescribed pressure
    share = gp / (1.0 + gp)
    t = np.asarray(time_s, float)
    x = np.empty_like(p)
    x[0], h = p[0], 0.0
    for i in range(1, p.size):
        step = max(float(t[i] - t[i - 1]), 0.0)
        a = math.exp(-step / tau_c)
        # exact for pressure linear in time over the row interval: dh/dt = (g' dp/dt - h/tau) / (1 + g')
        rise = (p[i] - p[i - 1]) * (1.0 if step == 0 else tau_c / step * (1.0 - a))
        h = a * h + share * rise
        x[i] = p[i] - h
    return x


def mullins_factor(pressure_kpa: np.ndarray, fraction: float, exponent: float = 2.0) -> np.ndarray:
    """Stiffness factor (>= 1) of every row from the running maximum of the pressure."""
    p = np.asarray(pressure_kpa, float)
    if fraction <= 0:
        return np.ones_like(p)
    previous = np.maximum.accumulate(np.concatenate([[0.0], p[:-1]]))
    first = p >= previous
    ratio = np.clip(p / np.where(previous > 0, previous, 1.0), 0.0, 1.0)
    return np.where(first, 1.0 + fraction, 1.0 + fraction * ratio ** exponent)
